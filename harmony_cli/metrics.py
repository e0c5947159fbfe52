"""Pure metric functions on the per-step table."""

from __future__ import annotations

import numpy as np
import pandas as pd


def time_stats_ms(values) -> dict[str, float]:
    """Median, p95 and max (and mean, never alone) of a series of times in ms."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"median": float("nan"), "p95": float("nan"), "max": float("nan"), "mean": float("nan")}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max()),
            "mean": float(v.mean())}


def tracking_error(steps: pd.DataFrame, hands: list[str]) -> dict[str, float]:
    """Max and RMS over time of the worse hand's position error [m]; worst rotation error [deg]."""
    err = steps[[f"{h}_error_m" for h in hands]].to_numpy().max(axis=1)
    rot = steps[[f"{h}_rot_error_deg" for h in hands]].to_numpy().max(axis=1)
    return {"max_m": float(err.max()), "rms_m": float(np.sqrt(np.mean(err**2))), "max_rot_deg": float(rot.max())}


def summarise(steps: pd.DataFrame, hands: list[str]) -> dict:
    return {
        "steps": int(len(steps)),
        "failed_solves": int((~steps["success"].astype(bool)).sum()),
        "held_last_plan": int(steps["held_last_plan"].astype(bool).sum()),
        "solve_time_ms": time_stats_ms(steps["solve_ms"]),
        "iterations_median": float(steps["iterations"].median()),
        "tracking_error": tracking_error(steps, hands),
    }
