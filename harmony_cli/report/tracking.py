"""A hand-trajectory run's verdict: whether the hands followed the reference within its tolerance.

A whole-body MPC can converge, step after step, to a solution that leaves the hands far from the reference (a
joint resting on a limit, a local minimum of the posture costs): every solve succeeds and the run completes. The
reference's tolerance (scenario `reference.tolerance`) turns that into a failed run: the hands may leave it only
for moments (a fast corner, a push), never for longer than its `duration`."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from enum import StrEnum
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.scenario.task import TrackingTolerance

if TYPE_CHECKING:
    import pandas as pd  # the steps table; importing this module does not load pandas (`harmony run` reads it late)


class Verdict(StrEnum):
    OK = "ok"
    FAILED = "failed"


@dataclass(frozen=True)
class Tracking:
    """The verdict, the tolerance it was judged by, and the longest time outside it (with when that began)."""

    verdict: Verdict
    position_m: float
    rotation_deg: float
    duration_s: float
    longest_outside_s: float
    outside_from_s: float | None  # where the longest time outside began (None: never outside)

    def as_dict(self) -> dict:
        """For summary.json: the fields, and the reason when the verdict is failed."""
        failed = {"reason": self.reason} if self.verdict is Verdict.FAILED else {}
        return asdict(self) | {"verdict": self.verdict.value} | failed

    @property
    def reason(self) -> str:
        """One line: what the hands did against the tolerance."""
        return (
            f"the hands were off the reference (beyond {100 * self.position_m:g} cm or {self.rotation_deg:g} deg) "
            f"for {self.longest_outside_s:.2f} s from t = {self.outside_from_s:.2f} s, longer than the "
            f"{self.duration_s:g} s the tolerance allows"
        )


def tracking_failed(summary: dict) -> bool:
    """Whether a summary.json's hands left the reference's tolerance (False for a run without a verdict: a task's)."""
    return summary.get("tracking", {}).get("verdict") == Verdict.FAILED


def tracking_verdict(steps: pd.DataFrame, hands: list[str], tolerance: TrackingTolerance, dt: float) -> Tracking:
    """Judge a run's steps (control period `dt` [s]) against `tolerance`: failed when some stretch of consecutive
    steps with either hand outside it lasts longer than its duration."""
    position = steps[[f"{h}_error_m" for h in hands]].to_numpy().max(axis=1)
    rotation = steps[[f"{h}_rot_error_deg" for h in hands]].to_numpy().max(axis=1)
    outside = (position > tolerance.position) | (rotation > tolerance.rotation_deg)
    longest, start = _longest_run(outside)
    seconds = longest * dt
    return Tracking(
        Verdict.FAILED if seconds > tolerance.duration + 1e-9 else Verdict.OK,
        tolerance.position,
        tolerance.rotation_deg,
        tolerance.duration,
        seconds,
        None if longest == 0 else float(steps["t"].iloc[start]),
    )


def _longest_run(flags: np.ndarray) -> tuple[int, int]:
    """The length of the longest stretch of True in `flags` and its first index (0, 0 when there is none)."""
    padded = np.r_[False, flags.astype(bool), False]
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    if len(starts) == 0:
        return 0, 0
    k = int(np.argmax(ends - starts))
    return int(ends[k] - starts[k]), int(starts[k])
