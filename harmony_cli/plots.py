"""Figures from run tables only (Agg backend, no screen)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_run(out: Path, steps: pd.DataFrame, hands: list[str]) -> None:
    """solve_time.png, hand_paths.png (top-down, reference vs measured) and tracking_error.png."""
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(steps["t"], steps["solve_ms"], lw=0.8)
    ax.axhline(steps["solve_ms"].median(), color="k", ls="--", lw=0.8, label="median")
    ax.set(xlabel="time [s]", ylabel="solve time [ms]", title="Whole-body MPC solve time per step")
    ax.legend()
    _save(fig, out / "solve_time.png")

    fig, ax = plt.subplots(figsize=(7, 5))
    for hand in hands:
        line, = ax.plot(steps[f"{hand}_ref_x"], steps[f"{hand}_ref_y"], "--", lw=1, label=f"{hand} reference")
        ax.plot(steps[f"{hand}_meas_x"], steps[f"{hand}_meas_y"], color=line.get_color(), lw=1.5,
                label=f"{hand} measured")
    if "q_base_x" in steps:
        ax.plot(steps["q_base_x"], steps["q_base_y"], color="grey", lw=1, label="base")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="Hand paths (top-down)", aspect="equal")
    ax.legend(fontsize=8)
    _save(fig, out / "hand_paths.png")

    fig, ax = plt.subplots(figsize=(7, 3))
    for hand in hands:
        ax.plot(steps["t"], 100 * steps[f"{hand}_error_m"], lw=1, label=hand)
    ax.set(xlabel="time [s]", ylabel="position error [cm]", title="Hand tracking error (measured vs reference)")
    ax.legend()
    _save(fig, out / "tracking_error.png")


def plot_comparison(out: Path, runs: dict[str, pd.DataFrame], hands: list[str], prefix: str = "fig4") -> list[Path]:
    """The paper's Fig. 4: (a) solve time per step, (b) tracking error, configurations overlaid."""
    paths = [out / f"{prefix}_solve_time.png", out / f"{prefix}_tracking_error.png"]
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for label, steps in runs.items():
        ax.plot(steps["t"], steps["solve_ms"], lw=0.8, label=label)
    ax.set(xlabel="time [s]", ylabel="solve time [ms]", yscale="log", title="(a) Whole-body MPC solve time")
    ax.legend(fontsize=8)
    _save(fig, paths[0])
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for label, steps in runs.items():
        err = steps[[f"{h}_error_m" for h in hands]].max(axis=1)
        ax.plot(steps["t"], 100 * err, lw=1, label=label)
    ax.set(xlabel="time [s]", ylabel="max hand error [cm]", title="(b) Tracking error")
    ax.legend(fontsize=8)
    _save(fig, paths[1])
    return paths
