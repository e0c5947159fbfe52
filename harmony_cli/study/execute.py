"""Where a study's runs execute: in this process (one job), on supervised local workers (`--jobs`, pool.py), or on a
Ray cluster (`--ray auto|ADDRESS`, ray_engine.py). Every engine runs the same function per run, which leaves a run
directory; the study reads its results from there, so the engines give the same rows.

A run executes in an attempt directory of its own and becomes a result only when the driver commits it: the attempt
directory renamed to the run's (atomic: a reader sees all of it or none of it). A run cut off by its driver's death
is never committed, so a study started again runs it again; a worker killed or lost mid-run, or a run that ignores
its wall-time limit, is committed by the driver with what its directory holds and the reason (`worker_lost`,
`timeout`) once retrying is spent.

A signal to the study ends every run in flight cleanly (each keeps its steps and says interrupted), starts no
more, and propagates."""

from __future__ import annotations

import io
import json
import os
import shutil
import tarfile
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from harmony_cli.experiment.faults import failed, write_whole
from harmony_cli.experiment.interrupts import RunTimedOut, signals_end_the_run, wall_time_limit
from harmony_cli.experiment.pipeline import RunFailed
from harmony_cli.experiment.run import run_scenario
from harmony_cli.scenario import ScenarioError

RUN_FILE = "study_run.json"
SUMMARY = "summary.json"
ATTEMPTS = ".attempts"  # under a study's runs/: the attempts in flight (never results until committed)


@dataclass(frozen=True)
class Job:
    """One run as an engine sees it: plain values (they cross process and machine boundaries)."""

    name: str
    scenario: str  # the base scenario file
    overrides: list[str]
    run_dir: str  # where its result is committed
    plots: str  # all | failed | none
    record: dict  # written to RUN_FILE: the study, sample, grid point, key, code version
    timeout: float | None = None  # [s] its wall-time limit
    attempt: str = ""  # this attempt's directory (attempt_dir)

    @property
    def attempt_dir(self) -> Path:
        run_dir = Path(self.run_dir)
        return run_dir.parent / ATTEMPTS / f"{run_dir.name}-{self.attempt}"

    def again(self) -> Job:
        """The job as a fresh attempt, in a directory of its own."""
        return replace(self, attempt=uuid.uuid4().hex[:8])


def ended(run_dir: Path) -> bool:
    """Whether the run in `run_dir` ended on its own: its summary.json is whole and says how (not still running)."""
    try:
        return json.loads((run_dir / SUMMARY).read_text()).get("status", "running") != "running"
    except (OSError, ValueError):
        return False


def run_job(job: Job) -> str:
    """Run one study run into its attempt directory; its status is in summary.json whatever happens (a run that
    fails is a result, not an error of the study). Returns the job's name."""
    out = job.attempt_dir
    shutil.rmtree(out, ignore_errors=True)  # a task run again (a lost node's) starts from nothing
    out.mkdir(parents=True)
    (out / RUN_FILE).write_text(json.dumps(job.record, indent=2))
    try:
        with wall_time_limit(job.timeout):
            run_scenario(job.scenario, job.overrides, out, progress=False, plots=job.plots)
    except (RunFailed, ScenarioError, OSError):
        pass  # summary.json and run.log say why
    except RunTimedOut:  # the limit came before or after the run's loop (its set-up, a push-free twin)
        if not ended(out):  # a run that had just ended keeps its result
            end_without_result(out, "timeout", "its wall-time limit was reached outside its control loop")
    return job.name


def end_without_result(out: Path, category: str, reason: str) -> None:
    """A run that did not end on its own, failed with `category` and `reason` in its summary.json; whatever else
    its directory holds (run.log, steps.jsonl so far) stays."""
    out.mkdir(parents=True, exist_ok=True)
    try:
        summary = json.loads((out / SUMMARY).read_text())
    except (OSError, ValueError):
        summary = {}
    summary = summary | failed(category, reason)
    write_whole(out / SUMMARY, json.dumps(summary, indent=2))
    with (out / "run.log").open("a") as log:
        log.write(f"run failed ({category}): {reason}\n")


def commit(job: Job) -> None:
    """The job's attempt becomes its result: the attempt directory renamed to the run's."""
    attempt, run_dir = job.attempt_dir, Path(job.run_dir)
    shutil.rmtree(run_dir, ignore_errors=True)
    os.replace(attempt, run_dir)


def run_job_packed(job: Job) -> tuple[str, bytes]:
    """run_job on a Ray worker, which may be another machine: the attempt directory comes back as a tar.gz."""
    run_job(job)
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        tar.add(job.attempt_dir, arcname=".")
    return job.name, buffer.getvalue()


def unpack(data: bytes, attempt_dir: Path) -> None:
    """An attempt directory from a worker, where the driver cannot see it (no shared file system)."""
    if ended(attempt_dir):
        return  # the worker wrote it where the driver sees it
    shutil.rmtree(attempt_dir, ignore_errors=True)
    attempt_dir.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        tar.extractall(attempt_dir, filter="data")


Done = Callable[[Job], None]  # called with a job whose attempt ended
Lost = Callable[[Job, str, str], None]  # called with a job that did not end on its own: category, reason


def run_here(jobs: Iterable[Job], done: Done) -> None:
    with signals_end_the_run():
        for job in jobs:
            run_job(job)
            done(job)
