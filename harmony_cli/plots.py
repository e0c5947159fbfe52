"""Figures from run tables only (Agg backend, no screen)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from harmony_cli.metrics import AFTER_PUSH_S  # noqa: E402


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


def plot_top_down(out: Path, steps: pd.DataFrame, scenario, hands: list[str], name: str = "top_down.png") -> None:
    """Base footprint every 2 s, base and hand paths, tables, obstacles, box path and goal (top-down)."""
    import numpy as np
    from matplotlib.patches import Circle, Polygon

    from harmony_cli.world import obstacle_shape, table_shape

    def outline(shape, **style):
        if shape.kind in ("cylinder", "sphere"):
            return Circle(shape.centre[:2], shape.half[0], **style)
        c, s = np.cos(shape.yaw), np.sin(shape.yaw)
        corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * shape.half[:2]
        return Polygon(shape.centre[:2] + corners @ np.array([[c, s], [-s, c]]), closed=True, **style)

    fig, ax = plt.subplots(figsize=(8, 6))
    for t in scenario.world.tables:
        ax.add_patch(outline(table_shape(t), fc="tan", ec="saddlebrown", alpha=0.6))
    for o in scenario.world.obstacles:
        shape = obstacle_shape(o)
        ax.add_patch(outline(shape, fc="indianred", ec="darkred", alpha=0.7))
        ax.annotate(o.name, shape.centre[:2], ha="center", fontsize=7)
    bx, by, byaw = (steps[f"q_{j}"].to_numpy() for j in scenario.robot.base_joints)
    ax.plot(bx, by, color="grey", lw=1.5, label="base")
    footprint = np.array(scenario.robot.footprint)  # the circles the whole-body MPC keeps clear, every 2 s
    for i in range(0, len(steps), max(1, int(round(2.0 / scenario.sim.control_dt)))):
        c, s = np.cos(byaw[i]), np.sin(byaw[i])
        for x, y, r in footprint:
            ax.add_patch(Circle((bx[i] + c * x - s * y, by[i] + s * x + c * y), r, fill=False, ec="grey", lw=0.4,
                                alpha=0.5))
    for hand in hands:
        ax.plot(steps[f"{hand}_meas_x"], steps[f"{hand}_meas_y"], lw=1, label=f"{hand} hand")
    if "box_x" in steps:
        ax.plot(steps["box_x"], steps["box_y"], color="darkorange", lw=1.5, label="box")
        if scenario.world.box.goal:
            ax.plot(*scenario.world.box.goal[:2], "k*", ms=10, label="box goal")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{scenario.name}: top-down", aspect="equal")
    ax.autoscale_view()
    ax.legend(fontsize=8, loc="best")
    _save(fig, out / name)


def _shade_phases(ax, steps: pd.DataFrame) -> None:
    """Alternate grey bands, one per task phase, labelled at the top."""
    if "phase" not in steps:
        return
    t, phase = steps["t"].to_numpy(), steps["phase"].to_numpy()
    starts = [0] + [i for i in range(1, len(phase)) if phase[i] != phase[i - 1]]
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    for n, i in enumerate(starts):
        end = t[starts[n + 1]] if n + 1 < len(starts) else t[-1] + dt
        if n % 2:
            ax.axvspan(t[i], end, color="0.9", lw=0)
        ax.text((t[i] + end) / 2, 1.0, phase[i], transform=ax.get_xaxis_transform(), ha="center", va="bottom",
                fontsize=7, rotation=30)


def _shade_push(ax, push, label: bool = True) -> None:
    ax.axvspan(push.start, push.start + push.duration, color="tab:red", alpha=0.15, lw=0,
               label=f"push {push.name}" if label else None)


def plot_forces(out: Path, steps: pd.DataFrame, hands: list[str], pushes=()) -> Path:
    """force_tracking.png: per hand, the sensed pad normal force (and PyBullet's pad-box contact force) against
    the squeeze-force reference when logged; task phases shaded and labelled, pushes in red."""
    fig, axes = plt.subplots(len(hands), 1, figsize=(9, 2.6 * len(hands)), sharex=True, squeeze=False)
    for ax, hand in zip(axes[:, 0], hands):
        _shade_phases(ax, steps)
        for n, push in enumerate(pushes):
            _shade_push(ax, push, label=n == 0 or len(pushes) > 1)
        if f"{hand}_force_ref_N" in steps:
            ax.plot(steps["t"], steps[f"{hand}_force_ref_N"], "k--", lw=1, label="reference")
        ax.plot(steps["t"], steps[f"{hand}_force_normal_N"], lw=1, label="measured (wrist sensor)")
        if f"{hand}_contact_N" in steps:
            ax.plot(steps["t"], steps[f"{hand}_contact_N"], lw=0.6, alpha=0.6, label="pad-box contact (PyBullet)")
        ax.set(ylabel=f"{hand} normal force [N]")
        ax.legend(fontsize=7, loc="upper left")
    axes[-1, 0].set(xlabel="time [s]")
    fig.suptitle("Squeeze force: reference vs measured (pad pressed > 0)")
    path = out / "force_tracking.png"
    _save(fig, path)
    return path


def plot_push(out: Path, steps: pd.DataFrame, hands: list[str], push, pushed_hand: str | None,
              before: float = 1.0, after: float = AFTER_PUSH_S) -> Path:
    """push_<name>.png: hand displacement (from the push-free run when logged, and from the live reference) and
    pad normal forces (sensed, reference, PyBullet contact) around one push."""
    end = push.start + push.duration
    part = steps[(steps["t"] >= push.start - before) & (steps["t"] <= end + after)]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for ax in (top, bottom):
        _shade_push(ax, push)
    for hand in hands:
        name = hand + (" (pushed)" if hand == pushed_hand else "")
        line, = top.plot(part["t"], 100 * part[f"{hand}_error_m"], lw=0.8, ls=":", label=f"{name} from reference")
        if f"{hand}_push_displacement_m" in part:
            top.plot(part["t"], 100 * part[f"{hand}_push_displacement_m"], color=line.get_color(),
                     lw=2 if hand == pushed_hand else 1, label=f"{name} from push-free run")
        line, = bottom.plot(part["t"], part[f"{hand}_force_normal_N"], lw=1, label=f"{hand} measured")
        if f"{hand}_force_ref_N" in part:
            bottom.plot(part["t"], part[f"{hand}_force_ref_N"], "--", color=line.get_color(), lw=1,
                        label=f"{hand} reference")
        if f"{hand}_contact_N" in part:
            bottom.plot(part["t"], part[f"{hand}_contact_N"], ":", color=line.get_color(), lw=1,
                        label=f"{hand} pad-box contact")
    top.axhline(1.0, color="k", ls="--", lw=0.6, label="1 cm")
    top.set(ylabel="hand displacement [cm]",
            title=f"push {push.name}: {list(push.force)} N on {push.body}"
                  f"{'/' + push.link if push.link else ''} for {push.duration:g} s")
    bottom.set(xlabel="time [s]", ylabel="pad normal force [N]")
    top.legend(fontsize=7)
    bottom.legend(fontsize=7)
    path = out / f"push_{push.name}.png"
    _save(fig, path)
    return path
