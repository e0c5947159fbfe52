"""Worker processes for many runs (`compare --jobs`, studies): started fresh, and ended cleanly on a signal."""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

STOP_S = 60.0  # [s] for the workers' runs to write their results after a signal, before they are killed


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """Workers started by spawn, not fork: none of this process's threads (a library's thread pool), locks or
    signal handlers carry over half-alive into them."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))


def end_workers(pool: ProcessPoolExecutor) -> None:
    """stop_processes on the pool's workers; the runs not started are cancelled."""
    workers = list(getattr(pool, "_processes", {}).values())
    stop_processes(workers, lambda: pool.shutdown(wait=False, cancel_futures=True))  # ended runs' workers exit
    pool.shutdown(wait=True, cancel_futures=True)


def stop_processes(workers: list, meanwhile: Callable[[], None] = lambda: None) -> None:
    """SIGTERM to every worker process (its run writes its results and stops), `meanwhile`, STOP_S for them to
    finish, then SIGKILL to any left."""
    for worker in workers:
        worker.terminate()
    meanwhile()
    deadline = time.monotonic() + STOP_S
    for worker in workers:
        worker.join(max(0.0, deadline - time.monotonic()))
    for worker in workers:
        if worker.is_alive():
            worker.kill()
