"""A study's local workers (`harmony study --jobs N`): long-lived processes, started by spawn, that run one job at a
time and keep what they built (a run's problem structures serve the next of the same shape), fed as they free up.
The driver supervises them:

- a run past its wall-time limit ends itself (SIGALRM, interrupts.py); one that has not GRACE_S later (held in a
  solver's C code) is killed with its worker and committed as `timeout`;
- a worker that dies mid-run (killed, out of memory) is replaced and its run started again, RETRIES times, then
  committed as `worker_lost`;
- a worker dies with its driver (Linux: the parent-death signal), so a driver killed outright leaves no run going
  on, and no run writes into the study after it;
- a signal to the driver ends every run in flight cleanly (experiment/workers.py's stop_processes: SIGTERM, time
  to write their results, then SIGKILL), starts no more, and propagates."""

from __future__ import annotations

import ctypes
import multiprocessing
import signal
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait

from harmony_cli.experiment.interrupts import RunInterrupted, signals_end_the_run
from harmony_cli.experiment.workers import stop_processes
from harmony_cli.study.execute import Done, Job, Lost, run_job

GRACE_S = 30.0  # [s] past its wall-time limit, a run that has not ended itself is killed
RETRIES = 1  # a run whose worker died is started again this often
PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """SIGTERM to this process when its parent dies (Linux; elsewhere nothing)."""
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _serve(conn: Connection, work: Callable[[Job], str]) -> None:
    """A worker's life: jobs in, names out, until told to stop (None) or its driver is gone."""
    _die_with_parent()
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        try:
            name = work(job)
        except RunInterrupted:
            return  # a signal ended its run, which wrote its results; the worker ends with it
        conn.send(name)


@dataclass
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: Connection
    job: Job | None = None
    tries: int = 0  # how often this job's runs were lost before
    started: float = 0.0


class Workers:
    """`n` supervised workers running `work` (run_job; tests give another) on jobs."""

    def __init__(self, n: int, done: Done, lost: Lost, work: Callable[[Job], str] = run_job):
        self.n, self.done, self.lost, self.work = n, done, lost, work
        self.context = multiprocessing.get_context("spawn")
        self.workers: list[_Worker] = []
        self.queue: deque[tuple[Job, int]] = deque()

    def run(self, jobs: list[Job]) -> None:
        self.queue.extend((job, 0) for job in jobs)
        with signals_end_the_run():
            try:
                while self.queue or any(w.job is not None for w in self.workers):
                    self._assign()
                    busy = [w for w in self.workers if w.job is not None]
                    wait([w.conn for w in busy] + [w.process.sentinel for w in busy], timeout=1.0)
                    for worker in busy:
                        self._check(worker)
            except RunInterrupted:
                self._end_all()
                raise
            finally:
                self._close()

    def _assign(self) -> None:
        for worker in [w for w in self.workers if w.job is None]:
            if not self.queue:
                break
            job, tries = self.queue.popleft()
            try:
                worker.conn.send(job)
            except OSError:  # the worker died while idle: a fresh one takes its place, the job waits for the next
                self.queue.appendleft((job, tries))
                self._replace(worker)
                continue
            worker.job, worker.tries, worker.started = job, tries, time.monotonic()
        while self.queue and len(self.workers) < self.n:
            self.workers.append(self._start())

    def _start(self) -> _Worker:
        parent, child = self.context.Pipe()
        process = self.context.Process(target=_serve, args=(child, self.work), daemon=True)
        process.start()
        child.close()
        return _Worker(process, parent)

    def _check(self, worker: _Worker) -> None:
        """A busy worker's news: its job done, its process dead, or its job past the limit and the grace."""
        job = worker.job
        assert job is not None
        if worker.conn.poll():
            try:
                worker.conn.recv()
            except EOFError:
                pass  # it died as it answered: seen as dead below
            else:
                worker.job = None
                self.done(job)
                return
        if not worker.process.is_alive():
            self._replace(worker)
            if worker.tries < RETRIES:
                self.queue.appendleft((job.again(), worker.tries + 1))
            else:
                code = worker.process.exitcode
                self.lost(job, "worker_lost", f"its worker died {RETRIES + 1} times (last exit code {code})")
            return
        limit = job.timeout
        if limit is not None and time.monotonic() - worker.started > limit + GRACE_S:
            worker.process.kill()
            worker.process.join()
            self._replace(worker)
            self.lost(job, "timeout", f"it did not stop within {GRACE_S:g} s of its wall-time limit ({limit:g} s)")

    def _replace(self, worker: _Worker) -> None:
        """A dead worker's place taken by a fresh one (nothing assigned)."""
        worker.conn.close()
        self.workers[self.workers.index(worker)] = self._start()

    def _end_all(self) -> None:
        """Every worker's run ended cleanly (stop_processes), no job started after."""
        self.queue.clear()
        stop_processes([worker.process for worker in self.workers])

    def _close(self) -> None:
        for worker in self.workers:
            if worker.process.is_alive():
                try:
                    worker.conn.send(None)
                except OSError:
                    worker.process.kill()
            worker.process.join(5.0)
            if worker.process.is_alive():
                worker.process.kill()
            worker.conn.close()
