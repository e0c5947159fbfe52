"""steps.jsonl: the per-step log streamed to disk during a run, one JSON object per line (rows may gain keys over
a run, e.g. a planner's, so not CSV). Rows are buffered and written when 0.1 s of wall time has passed since the
last write, so a run killed hard keeps all but its last 0.1 s; steps.csv is still written at the end. (Written
less often, each write serialises more rows at once: a pause in the loop that shows in its tail times.)"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

STREAM = "steps.jsonl"
EVERY_S = 0.1  # wall time between writes: what a hard kill may lose, and how many rows one write serialises


def _plain(value: object) -> object:
    """numpy scalars and arrays as JSON (NaN and inf stay, as Python's json reads and writes them)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


class StepStream:
    """Appends rows to `path`; serialising happens at write time, every EVERY_S, not in every control step."""

    def __init__(self, path: Path, every_s: float = EVERY_S):
        self.path = path
        self._file = path.open("w", encoding="utf-8")
        self._pending: list[dict] = []
        self._every = every_s
        self._last = time.monotonic()

    def add(self, row: dict) -> None:
        self._pending.append(row)
        if time.monotonic() - self._last >= self._every:
            self.flush()

    def flush(self) -> None:
        """One write call per batch of whole lines: a hard kill leaves at most a partial last line."""
        if self._pending:
            self._file.write("".join(json.dumps(row, default=_plain) + "\n" for row in self._pending))
            self._file.flush()
            self._pending.clear()
        self._last = time.monotonic()

    def close(self) -> None:
        """Idempotent; the file is closed even when the last write fails (a full disk)."""
        if not self._file.closed:
            try:
                self.flush()
            finally:
                self._file.close()


def read_stream(path: Path) -> list[dict]:
    """The rows of a steps.jsonl; a last line without its newline (cut by a hard kill mid-write) is ignored."""
    text = path.read_text(encoding="utf-8")
    lines = text.split("\n")
    rows = []
    for number, line in enumerate(lines[:-1], 1):  # the piece after the last newline is partial (or empty)
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}:{number}: not a JSON row ({exc.msg})") from None
    return rows
