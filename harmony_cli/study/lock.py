"""One driver per study directory. The driver holds `study.lock` (its host, pid and start) and touches it every
BEAT_S while it runs; a second `harmony study` on the directory is refused in one line. A lock is stale, and taken
over, when its driver is gone: its pid no longer alive on this host, or, from any host, no heartbeat for STALE_S
(a driver on another machine that lost its node)."""

from __future__ import annotations

import json
import os
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from harmony_cli.scenario import ScenarioError

LOCK = "study.lock"
BEAT_S = 5.0  # [s] how often a driver touches its lock
STALE_S = 60.0  # [s] a lock not touched for this long has no driver


class StudyLocked(ScenarioError):
    """Another driver runs the study directory."""


def _holder(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}  # being written, or damaged: judged by its age alone


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stale(path: Path, holder: dict) -> bool:
    """Whether the lock at `path`, held by `holder`, has no driver any more."""
    try:
        age = time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return True
    if age > STALE_S:
        return True
    here = holder.get("host") == socket.gethostname()
    return here and isinstance(holder.get("pid"), int) and not _alive(holder["pid"])


def _take(path: Path, me: dict) -> bool:
    """Create the lock as `me`; False if another holds it (a stale one is removed and creation tried again)."""
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            if not stale(path, _holder(path)):
                return False
            path.unlink(missing_ok=True)
            continue
        with os.fdopen(fd, "w") as f:
            json.dump(me, f)
        return True
    return False


@contextmanager
def study_lock(out: Path) -> Iterator[None]:
    """Hold `out`'s lock while inside (StudyLocked if another driver holds it)."""
    path = out / LOCK
    me = {"host": socket.gethostname(), "pid": os.getpid(), "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    if not _take(path, me):
        holder = _holder(path)
        who = f"host {holder.get('host', '?')}, pid {holder.get('pid', '?')}, since {holder.get('started', '?')}"
        raise StudyLocked(
            f"{out}: another `harmony study` is running on this directory ({who}); wait for it to end, or stop it "
            f"(a lock without a live driver is taken over after {STALE_S:g} s)"
        )
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(BEAT_S):
            try:
                os.utime(path)
            except OSError:
                return

    heart = threading.Thread(target=beat, name="harmony-study-lock", daemon=True)
    heart.start()
    try:
        yield
    finally:
        stop.set()
        heart.join()
        if _holder(path) == me:
            path.unlink(missing_ok=True)
