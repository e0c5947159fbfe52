"""Faults that end a run, each as a category (summary.json's `failure`) and a one-line reason: a solver that keeps
failing, a lost simulator, a full disk, a diverged simulation (health.py). What can still be written is: a write
that fails at the end marks the run failed and the writes after it go on."""

from __future__ import annotations

import errno
import os
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from harmony_cli.mpc.problem import NoPlanToHold
from harmony_cli.sim.engine import Simulator, simulator_errors

T = TypeVar("T")

# A held plan runs open loop: the whole-body plan is shifted, not re-solved from the measured state, and an old
# task plan no longer starts at the hands. A second (50 control steps, a third to half of the MPCs' horizons) is
# time for a solver to recover from a hard step; one that fails that long in a row is not recovering.
MAX_HELD_S = 1.0


class RunFault(RuntimeError):
    """A fault that ends a run: `category` (diverged, penetration, impossible, no stance, solver, simulator, disk,
    write) and `reason`."""

    def __init__(self, category: str, reason: str):
        super().__init__(reason)
        self.category, self.reason = category, reason


class HeldPlans:
    """Fails the run once the whole-body MPC, or the planner, has failed every solve for more than `limit_s` of
    simulated time (its last good plan held all along)."""

    def __init__(self, limit_s: float = MAX_HELD_S):
        self.limit = limit_s
        self.since: dict[str, float] = {}  # who -> the time of the first of its failures in a row

    def update(self, row: dict) -> None:
        t = row["t"]
        for who, ok, status in (
            ("whole-body MPC", row["success"], row["status"]),
            ("planner", row.get("planner_success"), row.get("planner_status")),  # only on re-planning steps
        ):
            if ok is None:
                continue
            if ok:
                self.since.pop(who, None)
                continue
            since = self.since.setdefault(who, t)
            if t - since > self.limit + 1e-9:
                raise RunFault(
                    "solver",
                    f"the {who} failed every solve from t = {since:.2f} s to t = {t:.2f} s (last: {status}); "
                    f"stopped: a plan is held for at most {self.limit:g} s",
                )


def stopped_at(rows: list[dict]) -> str:
    return f"after {len(rows)} steps (t = {rows[-1]['t']:.2f} s simulated)" if rows else "before its first step"


def _mount(path: Path) -> Path:
    path = path.resolve()
    while not os.path.ismount(path) and path != path.parent:
        path = path.parent
    return path


def write_failure(out: Path, what: str, exc: OSError) -> tuple[str, str]:
    """(category, reason) of a failed write of `what` into the run directory `out`."""
    if exc.errno == errno.ENOSPC:
        return "disk", f"disk full: no space left on the device of {_mount(out)} (writing {what} in {out})"
    return "write", f"could not write {what} in {out}: {exc.strerror or exc}"


def fault_of(exc: BaseException, out: Path, rows: list[dict], sim: Simulator | None) -> tuple[str, str]:
    """(category, reason) of the exception that ended a run after `rows`."""
    if isinstance(exc, RunFault):
        return exc.category, exc.reason
    if isinstance(exc, OSError) and exc.errno == errno.ENOSPC:
        category, reason = write_failure(out, exc.filename or "the run's files", exc)
        return category, f"{reason}; stopped {stopped_at(rows)}"
    text = str(exc).strip().splitlines()[-1] if str(exc).strip() else ""
    if isinstance(exc, NoPlanToHold):
        return "solver", f"{text}; stopped {stopped_at(rows)}"
    if isinstance(exc, simulator_errors()):
        lost = sim is not None and not sim.connected
        return "simulator", f"simulator {'connection lost' if lost else 'error'} ({text}); stopped {stopped_at(rows)}"
    return "error", f"{type(exc).__name__}: {text}"


def failed(category: str, reason: str) -> dict:
    """summary.json's fields for a failed run (`error`: the reason too, as before `failure` and `reason`)."""
    return {"status": "failed", "failure": category, "reason": reason, "error": reason}


def write_whole(path: Path, text: str) -> None:
    """`path` holds all of `text` or stays as it was: a full disk never leaves half a JSON file."""
    part = path.with_name(path.name + ".part")
    try:
        part.write_text(text)
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)


class Writes:
    """The end of a run's writes, each tried: one that fails marks the run failed in `summary` (one that already
    failed or was interrupted keeps its status) and the rest go on. `reason`: the first failure's."""

    def __init__(self, out: Path, summary: dict):
        self.out, self.summary = out, summary
        self.reason: str | None = None

    def __call__(self, what: str, write: Callable[[], T]) -> T | None:
        try:
            return write()
        except OSError as exc:
            category, reason = write_failure(self.out, what, exc)
            self.reason = self.reason or reason
            if self.summary.get("status") in ("running", "completed"):
                self.summary |= failed(category, reason)
            return None
