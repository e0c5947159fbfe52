"""loop_time.png: the control loop's time per step against its budget (the control period), and where it goes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.report.figure import plt, save

# steps.csv's breakdown of a step, in the order they run (the last two are the step before's: see loop.py)
PARTS = {
    "sense_ms": "sensing",
    "planner_ms": "planner",
    "wbmpc_ms": "whole-body MPC",
    "previous_log_ms": "logging",
    "previous_replay_ms": "replay log",
    "previous_physics_ms": "physics",
}


def plot_loop_time(out: Path, steps: pd.DataFrame, control_dt: float) -> None:
    """Left: histogram of the loop time (observation to command) with the control period; right: median, p99 and
    max of each part of a step. Nothing when the steps have no breakdown (runs before it existed)."""
    parts = {column: label for column, label in PARTS.items() if column in steps}
    if "sense_ms" not in parts:
        return
    budget = 1e3 * control_dt
    fig, (hist, bars) = plt.subplots(1, 2, figsize=(11, 3.5), gridspec_kw={"width_ratios": [3, 2]})
    loop = steps["loop_ms"].to_numpy()
    bins = np.linspace(0.0, max(budget, float(loop.max())) * 1.05, 80)
    hist.hist(loop, bins=bins, histtype="stepfilled", color="tab:blue", label="loop (planner + whole-body MPC)")
    hist.axvline(budget, color="tab:red", lw=1.2, label=f"control period {budget:g} ms")
    for q, style in ((50, "--"), (99, ":")):
        hist.axvline(np.percentile(loop, q), color="k", ls=style, lw=0.8, label=f"p{q} {np.percentile(loop, q):.2f}")
    hist.set(xlabel="time [ms]", ylabel="steps", yscale="log", title=f"Loop time per step (max {loop.max():.2f} ms)")
    hist.legend(fontsize=8)
    values = {label: steps[column].dropna().to_numpy() for column, label in parts.items()}
    y = np.arange(len(values))
    stats = {
        "median": [float(np.median(v)) for v in values.values()],
        "p99": [float(np.percentile(v, 99)) for v in values.values()],
        "max": [float(np.max(v)) for v in values.values()],
    }
    for offset, (name, stat) in enumerate(stats.items()):
        bars.barh(y + 0.27 * (offset - 1), stat, height=0.27, label=name)
    bars.set_yticks(y, list(values))
    bars.invert_yaxis()
    bars.set(xlabel="time per step [ms]", xscale="log", title="Where a step's time goes")
    bars.legend(fontsize=8)
    save(fig, out / "loop_time.png")
