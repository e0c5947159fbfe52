"""Top-down figures of a scene: tables, obstacles (moving ones as their tracks), the base footprint, base, hand and
box paths; several runs of one scene overlaid."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.collections import PatchCollection
from matplotlib.patches import Circle, Polygon

from harmony_cli.maths.shapes import obstacle_shape, table_shape
from harmony_cli.report.figure import plt, save

if TYPE_CHECKING:
    from harmony_cli.scenario.world import ObstacleSpec

if TYPE_CHECKING:
    from harmony_cli.scenario import Scenario


def _outline(shape, centre=None, **style):
    """A shape's top-down outline as a patch (at `centre` instead of its own when given)."""

    centre = shape.centre[:2] if centre is None else np.asarray(centre)[:2]
    if shape.kind in ("cylinder", "sphere"):
        return Circle(centre, shape.half[0], **style)
    c, s = np.cos(shape.yaw), np.sin(shape.yaw)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * shape.half[:2]
    return Polygon(centre + corners @ np.array([[c, s], [-s, c]]), closed=True, **style)


def _draw_obstacle(ax, spec: ObstacleSpec, steps: pd.DataFrame, colour: str = "indianred", label: str = "") -> None:
    """A static obstacle; a moving one as its track (logged by the simulator) with its outline where it started and
    where it came closest to the robot, labelled with that time."""

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


def _footprints(ax, steps: pd.DataFrame, scenario: Scenario, every: float = 2.0, colour: str = "grey") -> None:
    """The circles the whole-body MPC keeps clear, every `every` seconds (one collection: one artist to draw)."""

    bx, by, byaw = (steps[f"q_{j}"].to_numpy() for j in scenario.robot.base_joints)
    circles = []
    for i in range(0, len(steps), max(1, int(round(every / scenario.sim.control_dt)))):
        c, s = np.cos(byaw[i]), np.sin(byaw[i])
        circles += [Circle((bx[i] + c * x - s * y, by[i] + s * x + c * y), r) for x, y, r in scenario.robot.footprint]
    ax.add_collection(PatchCollection(circles, facecolor="none", edgecolor=colour, linewidths=0.4, alpha=0.5))


def plot_top_down(
    out: Path, steps: pd.DataFrame, scenario: Scenario, hands: list[str], name: str = "top_down.png"
) -> None:
    """Base footprint every 2 s, base and hand paths, tables, obstacles (moving ones: their tracks), box path and
    goal (top-down)."""
    fig, ax = plt.subplots(figsize=(8, 6))
    for t in scenario.world.tables:
        ax.add_patch(_outline(table_shape(t), fc="tan", ec="saddlebrown", alpha=0.6))
    for o in scenario.world.obstacles:
        _draw_obstacle(ax, o, steps)
    ax.plot(
        steps[f"q_{scenario.robot.base_joints[0]}"],
        steps[f"q_{scenario.robot.base_joints[1]}"],
        color="grey",
        lw=1.5,
        label="base",
    )
    _footprints(ax, steps, scenario)
    for hand in hands:
        ax.plot(steps[f"{hand}_meas_x"], steps[f"{hand}_meas_y"], lw=1, label=f"{hand} hand")
    if "box_x" in steps:
        ax.plot(steps["box_x"], steps["box_y"], color="darkorange", lw=1.5, label="box")
        goal = scenario.world.box.goal if scenario.world.box else None
        if goal:
            ax.plot(*goal[:2], "k*", ms=10, label="box goal")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"{scenario.name}: top-down", aspect="equal")
    ax.autoscale_view()
    ax.legend(fontsize=8, loc="best")
    save(fig, out / name)


def _draw_paths(ax, ax_t, label: str, steps: pd.DataFrame, scenario: Scenario, colour: str) -> None:
    """One run's base, hand and box paths (top-down, a dot every 2 s) and its progress against time."""
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


def plot_paths_compared(path: Path, runs: dict[str, tuple[pd.DataFrame, Scenario]], title: str = "") -> Path:
    """Runs of one scene overlaid, one colour each. Left, top-down: base, hand and box paths with a dot every 2 s,
    and each run's obstacles (a moving one as its track; tables and static obstacles once). Right, against time:
    how far the box (else the base) has gone, and the robot's clearance (simulator) to each moving obstacle."""
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
                ax_c.plot(
                    steps["t"],
                    steps[f"clearance_robot_{name}_m"],
                    color=colour,
                    ls=":",
                    lw=1.2,
                    label=f"{label}: robot to {name}",
                )
        _draw_paths(ax, ax_t, label, steps, scenario, colour)
    ax.plot([], [], color="k", lw=0.8, label="hands (thin)")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=title or f"{first.name}: paths compared", aspect="equal")
    ax.autoscale_view()
    ax.legend(fontsize=7, loc="best")
    ax_t.set(xlabel="time [s]", ylabel="distance travelled [m] (solid)", title="progress and clearance")
    ax_c.set_ylabel("clearance to the moving obstacle [m] (dotted)")
    ax_c.set_ylim(0, 2.0)
    moved = [
        t
        for steps, _ in runs.values()
        for name in moving
        if f"obstacle_{name}_x" in steps
        for t in steps["t"][steps[[f"obstacle_{name}_{a}" for a in "xyz"]].diff().abs().sum(axis=1) > 0]
    ]
    if moved:  # around the time the obstacles move
        ax_t.set_xlim(max(0.0, min(moved) - 5), max(moved) + 5)
    lines = ax_t.get_legend_handles_labels()
    more = ax_c.get_legend_handles_labels()
    ax_t.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper left")
    save(fig, path)
    return path
