"""A study's runs on a Ray cluster (`harmony study --ray auto|ADDRESS`): `auto` is the cluster this machine belongs
to, or a local one started for the study. Each run takes one CPU and its directory comes back to the driver.

Runs stream to the cluster as its CPUs free up (at most as many in flight as it has CPUs, so a run starts about
when it is handed over). A task whose worker or node is lost runs again (RAY_RETRIES times), then its run is
committed as `worker_lost`; a run that has not come back GRACE_S past its wall-time limit (its own alarm did not
end it) is cancelled with its worker and committed as `timeout`."""

from __future__ import annotations

import logging
import time
from collections import deque
from pathlib import Path

from harmony_cli.experiment.interrupts import RunInterrupted, signals_end_the_run
from harmony_cli.scenario import ScenarioError
from harmony_cli.study.execute import Done, Job, Lost, run_job_packed, unpack

RAY_RETRIES = 2  # Ray runs a task again this often when its worker or node is lost
GRACE_S = 30.0  # [s] past its wall-time limit (and START_S for Ray to start it), a run is cancelled
START_S = 30.0


def _connect(address: str):
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
    return ray, started


def run_ray(jobs: list[Job], address: str, done: Done, lost: Lost) -> None:
    ray, started = _connect(address)
    remote = ray.remote(num_cpus=1, max_retries=RAY_RETRIES, retry_exceptions=False)(run_job_packed)
    queue = deque(jobs)
    pending: dict[object, tuple[Job, float]] = {}  # task -> its job, when it was handed over
    expired: set[object] = set()  # tasks cancelled at their limit
    try:
        with signals_end_the_run():
            while queue or pending:
                while queue and len(pending) < max(1, int(ray.cluster_resources().get("CPU", 1))):
                    job = queue.popleft()
                    pending[remote.remote(job)] = (job, time.monotonic())
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
                for ref in ready:
                    _collect(ray, ref, pending.pop(ref)[0], ref in expired, done, lost)
                _expire(ray, pending, expired)
    except RunInterrupted:
        for ref in pending:
            ray.cancel(ref)  # SIGINT to the worker: its run writes its results and stops
        raise
    finally:
        if started:
            ray.shutdown()


def _collect(ray, ref, job: Job, cancelled: bool, done: Done, lost: Lost) -> None:
    """A finished task's run: its directory brought back and committed, or why there is none."""
    from ray.exceptions import RayError

    try:
        _, data = ray.get(ref)
    except RayError as exc:
        if cancelled:
            lost(job, "timeout", f"it did not stop within {GRACE_S:g} s of its wall-time limit ({job.timeout:g} s)")
        else:
            lost(job, "worker_lost", f"its Ray worker was lost {RAY_RETRIES + 1} times ({type(exc).__name__})")
        return
    unpack(data, Path(job.attempt_dir))
    done(job)


def _expire(ray, pending: dict, expired: set) -> None:
    """Cancel, with their workers, the runs past their limit, GRACE_S and START_S since they were handed over."""
    now = time.monotonic()
    for ref, (job, handed) in pending.items():
        if ref not in expired and job.timeout is not None and now - handed > job.timeout + GRACE_S + START_S:
            ray.cancel(ref, force=True)
            expired.add(ref)
