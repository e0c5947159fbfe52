"""SIGTERM, SIGINT and SIGHUP during a run end it cleanly: the handler raises RunInterrupted at the current step
(the loop is Python around C calls that return within milliseconds), the run writes its results, and the command
exits 128 + the signal's number. Further signals are ignored once the run is stopping or writing its results, so a
second Ctrl-C or `kill` cannot cut summary.json short.

A wall-time limit (`wall_time_limit`, a study's `--run-timeout`) is SIGALRM at the limit: the run ends the same way
at its current step, as a failure of category `timeout` instead of an interruption."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGALRM)


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by a signal; its directory holds the steps so far and summary.json (status interrupted).
    A KeyboardInterrupt: `except Exception` in solvers or callers never swallows it, and click reports it."""

    def __init__(self, signal_name: str, run_dir: Path | None = None):
        super().__init__(signal_name)
        self.signal_name = signal_name
        self.run_dir = run_dir

    @property
    def exit_code(self) -> int:
        return 128 + int(signal.Signals[self.signal_name])


class RunTimedOut(RunInterrupted):
    """A run stopped at its wall-time limit (SIGALRM): a failure of category `timeout`, with its steps so far."""

    def __init__(self, run_dir: Path | None = None):
        super().__init__(signal.SIGALRM.name, run_dir)


def stopped_by(signal_name: str) -> RunInterrupted:
    """The exception a signal stops a run with: RunTimedOut for the wall-time limit's SIGALRM."""
    return RunTimedOut() if signal_name == signal.SIGALRM.name else RunInterrupted(signal_name)


class Guard:
    """The state the handlers share: whether the run is already stopping (or writing its results)."""

    def __init__(self) -> None:
        self.stopping = False
        self.received: str | None = None  # the signal that stops the run

    def handle(self, signum: int, frame: object) -> None:
        if self.stopping:  # a second signal, or one while the results are written: let them be written
            return
        self.stopping, self.received = True, signal.Signals(signum).name
        raise stopped_by(self.received)

    def check(self) -> None:
        """Called every step: raises again a RunInterrupted that a library swallowed (raised inside a solver's
        Python callback, IPOPT reports a failed solve and the loop would go on with later signals ignored)."""
        if self.received is not None:
            raise stopped_by(self.received)

    def hold(self) -> None:
        """From here on (writing the results) signals are ignored."""
        self.stopping = True


@contextmanager
def signals_end_the_run() -> Iterator[Guard]:
    """Inside, SIGTERM / SIGINT / SIGHUP raise RunInterrupted once; the previous handlers come back after. Only the
    main thread may set handlers: elsewhere (a library caller's thread) the signals keep their handlers."""
    guard = Guard()
    if threading.current_thread() is not threading.main_thread():
        yield guard
        return
    # a signal ignored by whoever started us (nohup: SIGHUP; `cmd &` in a script: SIGINT) stays ignored
    previous = {s: h for s in SIGNALS if (h := signal.getsignal(s)) != signal.SIG_IGN}
    for s in previous:
        signal.signal(s, guard.handle)
    try:
        yield guard
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)


@contextmanager
def wall_time_limit(seconds: float | None) -> Iterator[None]:
    """Inside, SIGALRM after `seconds` of wall time (None: no limit) raises RunTimedOut: in a run, at its current
    step (its guard handles SIGALRM); before or after it, where the alarm finds the process. Main thread only (an
    alarm is the process's): elsewhere no limit is set."""
    if seconds is None or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expired(signum: int, frame: object) -> None:
        raise RunTimedOut()

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def steps_so_far(rows: list[dict]) -> str:
    """How far a stopped run got: after how many steps, at what simulated time."""
    return f"after {len(rows)} steps (t = {rows[-1]['t']:.2f} s simulated)" if rows else "before its first step"


def interrupted_summary(exc: RunInterrupted, rows: list[dict]) -> dict:
    """summary.json's status, signal and reason for a run stopped by `exc` after `rows`."""
    reason = f"{exc.signal_name} received; stopped {steps_so_far(rows)}"
    return {"status": "interrupted", "signal": exc.signal_name, "reason": reason}
