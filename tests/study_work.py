"""Stand-ins for a study run's work, for the supervised workers' tests (module level: a spawned worker imports them).
Each leaves an attempt directory as a run would, or dies trying."""

from __future__ import annotations

import json
import os
import signal
import time

from harmony_cli.study.execute import RUN_FILE, Job


def _start(job: Job) -> None:
    job.attempt_dir.mkdir(parents=True, exist_ok=True)
    (job.attempt_dir / RUN_FILE).write_text(json.dumps(job.record))
    (job.attempt_dir / "run.log").write_text("started\n")


def completes(job: Job) -> str:
    _start(job)
    (job.attempt_dir / "summary.json").write_text(json.dumps({"status": "completed"}))
    return job.name


def ignores_its_limit(job: Job) -> str:
    """A run held where its wall-time limit cannot reach it (as in a solver's C code)."""
    _start(job)
    signal.signal(signal.SIGALRM, signal.SIG_IGN)
    time.sleep(600)
    return job.name


def dies(job: Job) -> str:
    """A worker killed mid-run (out of memory, a node's pre-emption)."""
    _start(job)
    os.kill(os.getpid(), signal.SIGKILL)
    return job.name


def dies_once(job: Job) -> str:
    """A worker lost on the job's first attempt only (a marker beside the study's runs remembers)."""
    marker = job.attempt_dir.parent / f"{job.name}.died"
    if not marker.exists():
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
        return dies(job)
    return completes(job)
