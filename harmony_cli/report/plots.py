"""Figures from run tables only (Agg backend, no screen)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from harmony_cli.maths.shapes import obstacle_shape, table_shape  # noqa: E402
from harmony_cli.report.metrics import AFTER_PUSH_S  # noqa: E402


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_run_dir(out: Path, steps: pd.DataFrame, scenario, summary: dict) -> None:
    """Every figure of a run directory: solve time, hand paths, tracking error; the top-down view of a task; force
    tracking and each push's response when the run has them."""
    hands = list(scenario.robot.end_effectors)
    plot_run(out, steps, hands)
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


def _outline(shape, centre=None, **style):
    """A shape's top-down outline as a patch (at `centre` instead of its own when given)."""
    import numpy as np
    from matplotlib.patches import Circle, Polygon

    centre = shape.centre[:2] if centre is None else np.asarray(centre)[:2]
    if shape.kind in ("cylinder", "sphere"):
        return Circle(centre, shape.half[0], **style)
    c, s = np.cos(shape.yaw), np.sin(shape.yaw)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * shape.half[:2]
    return Polygon(centre + corners @ np.array([[c, s], [-s, c]]), closed=True, **style)


def _draw_obstacle(ax, spec, steps: pd.DataFrame, colour: str = "indianred", label: str = "") -> None:
    """A static obstacle; a moving one as its track (logged by PyBullet) with its outline where it started and
    where it came closest to the robot, labelled with that time."""
    import numpy as np

    shape = obstacle_shape(spec)
    columns = [f"obstacle_{spec.name}_{a}" for a in "xy"]
    if spec.motion is None or not set(columns) <= set(steps.columns):
        ax.add_patch(_outline(shape, fc=colour, ec="darkred", alpha=0.7))
        ax.annotate(spec.name, shape.centre[:2], ha="center", fontsize=7)
        return
    track = steps[columns].to_numpy()
    ax.plot(*track.T, ls=":", color=colour, lw=1.5, label=f"{label}{spec.name} track")
    ax.add_patch(_outline(shape, track[0], fc="none", ec=colour, ls="--", lw=1))
    clearance = f"clearance_robot_{spec.name}_m"
    i = int(np.argmin(steps[clearance].to_numpy())) if clearance in steps else len(track) - 1
    ax.add_patch(_outline(shape, track[i], fc=colour, ec="darkred", alpha=0.5))
    ax.annotate(f"{spec.name}\nt = {steps['t'].iloc[i]:.1f} s", track[i], ha="center", fontsize=7)


def _footprints(ax, steps: pd.DataFrame, scenario, every: float = 2.0, colour: str = "grey") -> None:
    """The circles the whole-body MPC keeps clear, every `every` seconds."""
    import numpy as np
    from matplotlib.patches import Circle

    bx, by, byaw = (steps[f"q_{j}"].to_numpy() for j in scenario.robot.base_joints)
    for i in range(0, len(steps), max(1, int(round(every / scenario.sim.control_dt)))):
        c, s = np.cos(byaw[i]), np.sin(byaw[i])
        for x, y, r in scenario.robot.footprint:
            ax.add_patch(Circle((bx[i] + c * x - s * y, by[i] + s * x + c * y), r, fill=False, ec=colour, lw=0.4,
                                alpha=0.5))


def plot_top_down(out: Path, steps: pd.DataFrame, scenario, hands: list[str], name: str = "top_down.png") -> None:
    """Base footprint every 2 s, base and hand paths, tables, obstacles (moving ones: their tracks), box path and
    goal (top-down)."""
    fig, ax = plt.subplots(figsize=(8, 6))
    for t in scenario.world.tables:
        ax.add_patch(_outline(table_shape(t), fc="tan", ec="saddlebrown", alpha=0.6))
    for o in scenario.world.obstacles:
        _draw_obstacle(ax, o, steps)
    ax.plot(steps[f"q_{scenario.robot.base_joints[0]}"], steps[f"q_{scenario.robot.base_joints[1]}"], color="grey",
            lw=1.5, label="base")
    _footprints(ax, steps, scenario)
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


def plot_paths_compared(path: Path, runs: dict[str, tuple[pd.DataFrame, object]], title: str = "") -> Path:
    """Runs of one scene overlaid, one colour each. Left, top-down: base, hand and box paths with a dot every 2 s,
    and each run's obstacles (a moving one as its track; tables and static obstacles once). Right, against time:
    how far the box (else the base) has gone, and the robot's PyBullet clearance to each moving obstacle."""
    import numpy as np

    fig, (ax, ax_t) = plt.subplots(1, 2, figsize=(14, 6), gridspec_kw={"width_ratios": [1.6, 1]})
    first = next(iter(runs.values()))[1]  # the scene's tables
    for t in first.world.tables:
        ax.add_patch(_outline(table_shape(t), fc="tan", ec="saddlebrown", alpha=0.6))
    colours, drawn = plt.rcParams["axes.prop_cycle"].by_key()["color"], set()
    ax_c = ax_t.twinx()
    moving = sorted({o.name for _, scenario in runs.values() for o in scenario.world.obstacles if o.motion})
    for (label, (steps, scenario)), colour in zip(runs.items(), colours):
        for o in scenario.world.obstacles:
            if o.motion is None and (o.name, o.position) in drawn:
                continue  # static and already drawn for another run
            drawn.add((o.name, o.position))
            _draw_obstacle(ax, o, steps, colour if o.motion is not None else "indianred", f"{label}: ")
        for name in moving:  # also where it stands still in this run
            if f"clearance_robot_{name}_m" in steps:
                ax_c.plot(steps["t"], steps[f"clearance_robot_{name}_m"], color=colour, ls=":", lw=1.2,
                          label=f"{label}: robot to {name}")
        bx, by = (steps[f"q_{j}"].to_numpy() for j in scenario.robot.base_joints[:2])
        every = max(1, int(round(2.0 / scenario.sim.control_dt)))
        ax.plot(bx, by, color=colour, lw=2, label=f"{label}: base (dots every 2 s)")
        ax.plot(bx[::every], by[::every], "o", color=colour, ms=3)
        for hand in scenario.robot.end_effectors:
            ax.plot(steps[f"{hand}_meas_x"], steps[f"{hand}_meas_y"], color=colour, lw=0.8, alpha=0.8)
        track = steps[["box_x", "box_y"]].to_numpy() if "box_x" in steps else np.column_stack([bx, by])
        if "box_x" in steps:
            ax.plot(*track.T, color=colour, lw=1.2, ls="-.", label=f"{label}: box")
            ax.plot(*track[::every].T, "s", color=colour, ms=3)
        travelled = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(track, axis=0), axis=1))]
        what = "box" if "box_x" in steps else "base"
        ax_t.plot(steps["t"], travelled, color=colour, lw=1.5, label=f"{label}: {what}")
    ax.plot([], [], color="k", lw=0.8, label="hands (thin)")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=title or f"{first.name}: paths compared", aspect="equal")
    ax.autoscale_view()
    ax.legend(fontsize=7, loc="best")
    ax_t.set(xlabel="time [s]", ylabel="distance travelled [m] (solid)", title="progress and clearance")
    ax_c.set_ylabel("clearance to the moving obstacle [m] (dotted)")
    ax_c.set_ylim(0, 2.0)
    moved = [t for steps, _ in runs.values() for name in moving if f"obstacle_{name}_x" in steps
             for t in steps["t"][steps[[f"obstacle_{name}_{a}" for a in "xyz"]].diff().abs().sum(axis=1) > 0]]
    if moved:  # around the time the obstacles move
        ax_t.set_xlim(max(0.0, min(moved) - 5), max(moved) + 5)
    lines = ax_t.get_legend_handles_labels()
    more = ax_c.get_legend_handles_labels()
    ax_t.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper left")
    _save(fig, path)
    return path


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
    if f"push_{push.name}_N" in part:
        bottom.plot(part["t"], part[f"push_{push.name}_N"], color="k", lw=1.5, label=f"pusher ({push.name})")
    top.axhline(1.0, color="k", ls="--", lw=0.6, label="1 cm")
    kind = f"{list(push.force)} N" if push.stiffness is None else \
        f"spring {push.stiffness:g} N/m, max {math.hypot(*push.force):g} N"
    top.set(ylabel="hand displacement [cm]", title=f"push {push.name}: {kind} on {push.body}"
                                                   f"{'/' + push.link if push.link else ''} for {push.duration:g} s")
    bottom.set(xlabel="time [s]", ylabel="force [N]")
    top.legend(fontsize=7)
    bottom.legend(fontsize=7)
    path = out / f"push_{push.name}.png"
    _save(fig, path)
    return path
