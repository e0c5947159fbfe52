"""The figures of a run directory and the paper's Fig. 4 (solve time and tracking error of several runs)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from harmony_cli.report.figure import plt, save
from harmony_cli.report.force_plots import plot_forces, plot_push
from harmony_cli.report.scene_plots import plot_top_down
from harmony_cli.report.timing_plots import plot_loop_time

if TYPE_CHECKING:
    from harmony_cli.scenario import Scenario


def plot_run_dir(
    out: Path, steps: pd.DataFrame, scenario: Scenario, summary: dict, part: int = 0, parts: int = 1
) -> None:
    """Every figure of a run directory: solve time, loop time, hand paths, tracking error; the top-down view of a
    task; force tracking and each push's response when the run has them. `part` of `parts`: every parts-th figure
    from the part-th on (processes that share the drawing draw disjoint sets)."""
    for draw in run_figures(steps, scenario, summary)[part::parts]:
        draw(out)


def run_figures(steps: pd.DataFrame, scenario: Scenario, summary: dict) -> list[Callable[[Path], object]]:
    """A run directory's figures, each a function of the directory it draws into, in a fixed order (the slowest
    to draw first)."""
    hands = list(scenario.robot.end_effectors)
    figures: list[Callable[[Path], object]] = [lambda out: plot_loop_time(out, steps, scenario.sim.control_dt)]
    if scenario.task is not None:  # second: the two slowest to draw go to two processes that share them
        figures.append(lambda out: plot_top_down(out, steps, scenario, hands))
    figures += [
        lambda out: plot_solve_time(out, steps),
        lambda out: plot_hand_paths(out, steps, hands),
        lambda out: plot_tracking_error(out, steps, hands),
    ]
    if scenario.pushes or any(c.endswith("_force_ref_N") for c in steps.columns):
        figures.append(lambda out: plot_forces(out, steps, hands, scenario.pushes))
        pushes = summary.get("task", summary).get("pushes", {})
        figures += [
            partial(plot_push, steps=steps, hands=hands, push=push, pushed_hand=pushes[push.name]["pushed_hand"])
            for push in scenario.pushes
        ]
    return figures


def plot_solve_time(out: Path, steps: pd.DataFrame) -> None:
    """solve_time.png: the whole-body MPC's solve time per step and its median."""
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(steps["t"], steps["solve_ms"], lw=0.8)
    ax.axhline(steps["solve_ms"].median(), color="k", ls="--", lw=0.8, label="median")
    ax.set(xlabel="time [s]", ylabel="solve time [ms]", title="Whole-body MPC solve time per step")
    ax.legend()
    save(fig, out / "solve_time.png")


def plot_hand_paths(out: Path, steps: pd.DataFrame, hands: list[str]) -> None:
    """hand_paths.png: top-down, each hand's reference and measured path, and the base's."""
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


def plot_tracking_error(out: Path, steps: pd.DataFrame, hands: list[str]) -> None:
    """tracking_error.png: each hand's distance from its reference over time."""
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
