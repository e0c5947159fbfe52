"""Where a study's runs execute: in this process (one job), on a local process pool (`--jobs`), or on a Ray cluster
(`--ray auto|ADDRESS`). Every engine runs the same function per run, which leaves a run directory; the study
reads its results from there, so the engines give the same rows.

A signal to the study ends every run in flight cleanly (each keeps its steps and says interrupted), starts no
more, and propagates."""

from __future__ import annotations

import io
import json
import logging
import tarfile
from collections.abc import Callable, Iterable
from concurrent.futures import as_completed
from dataclasses import dataclass
from pathlib import Path

from harmony_cli.experiment.interrupts import RunInterrupted, signals_end_the_run
from harmony_cli.experiment.pipeline import RunFailed
from harmony_cli.experiment.run import run_scenario
from harmony_cli.experiment.workers import end_workers, worker_pool
from harmony_cli.scenario import ScenarioError

RUN_FILE = "study_run.json"


@dataclass(frozen=True)
class Job:
    """One run as an engine sees it: plain values (they cross process and machine boundaries)."""

    name: str
    scenario: str  # the base scenario file
    overrides: list[str]
    run_dir: str
    plots: str  # all | failed | none
    record: dict  # written to RUN_FILE: the study, sample, grid point, key, code version


def run_job(job: Job) -> str:
    """Run one study run into its directory; its status is in summary.json whatever happens (a run that fails
    is a result, not an error of the study). Returns the job's name."""
    out = Path(job.run_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / RUN_FILE).write_text(json.dumps(job.record, indent=2))
    try:
        run_scenario(job.scenario, job.overrides, out, progress=False, plots=job.plots)
    except (RunFailed, ScenarioError, OSError):
        pass  # summary.json and run.log say why
    return job.name


def run_job_packed(job: Job) -> tuple[str, bytes]:
    """run_job on a Ray worker, which may be another machine: the run directory comes back as a tar.gz."""
    run_job(job)
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        tar.add(job.run_dir, arcname=".")
    return job.name, buffer.getvalue()


def unpack(data: bytes, run_dir: Path) -> None:
    """A run directory from a worker, where the driver cannot see it (no shared file system)."""
    if (run_dir / "summary.json").is_file():
        return  # the worker wrote it where the driver sees it
    run_dir.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        tar.extractall(run_dir, filter="data")


Done = Callable[[str], None]  # called with a job's name as it finishes


def run_here(jobs: Iterable[Job], done: Done) -> None:
    with signals_end_the_run():
        for job in jobs:
            done(run_job(job))


def run_pool(jobs: list[Job], workers: int, done: Done) -> None:
    with signals_end_the_run(), worker_pool(workers) as pool:
        try:
            for future in as_completed([pool.submit(run_job, job) for job in jobs]):
                done(future.result())
        except RunInterrupted:
            end_workers(pool)
            raise


def run_ray(jobs: list[Job], address: str, done: Done) -> None:
    """On a Ray cluster (`auto`: the one this machine belongs to, or a local one started for the study; or a
    cluster's address). Each run takes one CPU; its directory comes back to this machine."""
    try:
        import ray
    except ImportError:
        raise ScenarioError("--ray needs Ray: pip install 'harmony-cli[ray]' (or `make install`)") from None
    started = not ray.is_initialized()
    if started:
        try:
            ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
        except ConnectionError:
            if address != "auto":
                raise ScenarioError(f"--ray {address}: no Ray cluster answers there") from None
            ray.init(logging_level=logging.ERROR, log_to_driver=False)  # no cluster running: a local one for this study
    remote = ray.remote(num_cpus=1, max_retries=0)(run_job_packed)
    pending = {remote.remote(job): job for job in jobs}
    try:
        with signals_end_the_run():
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                job = pending.pop(ready[0])
                name, data = ray.get(ready[0])
                unpack(data, Path(job.run_dir))
                done(name)
    except RunInterrupted:
        for ref in pending:
            ray.cancel(ref)  # SIGINT to the worker: its run writes its results and stops
        raise
    finally:
        if started:
            ray.shutdown()
