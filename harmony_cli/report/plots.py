"""The figures of a run directory and the paper's Fig. 4 (solve time and tracking error of several runs)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from harmony_cli.report.figure import plt, save
from harmony_cli.report.force_plots import plot_forces, plot_push
from harmony_cli.report.scene_plots import plot_top_down
from harmony_cli.report.timing_plots import plot_loop_time

if TYPE_CHECKING:
    from harmony_cli.scenario import Scenario


def plot_run_dir(out: Path, steps: pd.DataFrame, scenario: Scenario, summary: dict) -> None:
    """Every figure of a run directory: solve time, loop time, hand paths, tracking error; the top-down view of a
    task; force tracking and each push's response when the run has them."""
    hands = list(scenario.robot.end_effectors)
    plot_run(out, steps, hands)
    plot_loop_time(out, steps, scenario.sim.control_dt)
    if scenario.task is not None:
        plot_top_down(out, steps, scenario, hands)
    if scenario.pushes or any(c.endswith("_force_ref_N") for c in steps.columns):
        plot_forces(out, steps, hands, scenario.pushes)
        pushes = summary.get("task", summary).get("pushes", {})
        for push in scenario.pushes:
            plot_push(out, steps, hands, push, pushes[push.name]["pushed_hand"])


def plot_run(out: Path, steps: pd.DataFrame, hands: list[str]) -> None:
    """solve_time.png, hand_paths.png (top-down, reference vs measured) and tracking_error.png."""
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(steps["t"], steps["solve_ms"], lw=0.8)
    ax.axhline(steps["solve_ms"].median(), color="k", ls="--", lw=0.8, label="median")
    ax.set(xlabel="time [s]", ylabel="solve time [ms]", title="Whole-body MPC solve time per step")
    ax.legend()
    save(fig, out / "solve_time.png")

    fig, ax = plt.subplots(figsize=(7, 5))
    for hand in hands:
        (line,) = ax.plot(steps[f"{hand}_ref_x"], steps[f"{hand}_ref_y"], "--", lw=1, label=f"{hand} reference")
        ax.plot(
            steps[f"{hand}_meas_x"], steps[f"{hand}_meas_y"], color=line.get_color(), lw=1.5, label=f"{hand} measured"
        )
    if "q_base_x" in steps:
        ax.plot(steps["q_base_x"], steps["q_base_y"], color="grey", lw=1, label="base")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="Hand paths (top-down)", aspect="equal")
    ax.legend(fontsize=8)
    save(fig, out / "hand_paths.png")

    fig, ax = plt.subplots(figsize=(7, 3))
    for hand in hands:
        ax.plot(steps["t"], 100 * steps[f"{hand}_error_m"], lw=1, label=hand)
    ax.set(xlabel="time [s]", ylabel="position error [cm]", title="Hand tracking error (measured vs reference)")
    ax.legend()
    save(fig, out / "tracking_error.png")


def plot_comparison(out: Path, runs: dict[str, pd.DataFrame], hands: list[str], prefix: str = "fig4") -> list[Path]:
    """The paper's Fig. 4: (a) solve time per step, (b) tracking error, configurations overlaid."""
    paths = [out / f"{prefix}_solve_time.png", out / f"{prefix}_tracking_error.png"]
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for label, steps in runs.items():
        ax.plot(steps["t"], steps["solve_ms"], lw=0.8, label=label)
    ax.set(xlabel="time [s]", ylabel="solve time [ms]", yscale="log", title="(a) Whole-body MPC solve time")
    ax.legend(fontsize=8)
    save(fig, paths[0])
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for label, steps in runs.items():
        err = steps[[f"{h}_error_m" for h in hands]].max(axis=1)
        ax.plot(steps["t"], 100 * err, lw=1, label=label)
    ax.set(xlabel="time [s]", ylabel="max hand error [cm]", title="(b) Tracking error")
    ax.legend(fontsize=8)
    save(fig, paths[1])
    return paths
