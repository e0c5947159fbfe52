"""The study's map: every draw in plan view over the base scene, coloured by its run's outcome.

The fixed scene (tables, the obstacles at their base positions, the box and its goal, the robot's start) comes
from the base scenario as a plain mapping; each draw adds its robot start (a dot with a heading tick), its box (a
square) and each varied obstacle (its outline at its true size), all in the colour of the run's outcome. Only
varied fields that are positions are drawn (`vary.<field>.<component>` with the field ending in `base_pose` or
`position`); a component not varied is the scene's. Failures are drawn over successes so that a few of them show
among many; with several grid points each has its own panel, since one draw may succeed at one point and fail
at another."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon

from harmony_cli.report.figure import plt, save
from harmony_cli.study.sampling import value_at
from harmony_cli.study.table import IMPOSSIBLE, SUCCESS_LATE
from harmony_cli.study.table import SUCCESS as OUTCOME_SUCCESS

POSITIONAL = re.compile(r"^vary\.(?P<field>(?:.+\.)?(?:base_pose|position))\.(?P<axis>[0-2])$")
SUCCESS, LATE_SUCCESS, REFUSED, NO_RESULT = "tab:green", "yellowgreen", "0.5", "0.78"
FAILURES = ("tab:red", "tab:orange", "tab:purple", "tab:blue", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")
HEADING_M = 0.35  # length of a start's heading tick
LABELLED = 20  # at most this many runs that did not succeed get their sample number written on the map


def positional_fields(table: pd.DataFrame) -> dict[str, dict[int, str]]:
    """The varied fields that are positions: field -> {component: column}."""
    fields: dict[str, dict[int, str]] = {}
    for column in table.columns:
        if match := POSITIONAL.match(column):
            fields.setdefault(match["field"], {})[int(match["axis"])] = column
    return fields


def outcome_colours(outcomes: pd.Series) -> dict[str, str]:
    """Success green (a lighter green with a phase that ended late), refused or impossible draws dark grey, runs
    without a result light grey, and each other outcome (a failure) its own colour, the most frequent first."""
    counts = outcomes.value_counts()
    colours, failures = {}, 0
    for outcome in sorted(counts.index, key=lambda o: (-counts[o], str(o))):
        rank = _rank(str(outcome))
        if rank < 3:
            late = str(outcome) == SUCCESS_LATE
            colours[str(outcome)] = LATE_SUCCESS if late else (SUCCESS, REFUSED, NO_RESULT)[rank]
        else:
            colours[str(outcome)] = FAILURES[failures % len(FAILURES)]
            failures += 1
    return colours


def _rank(outcome: str) -> int:
    """The drawing order: success first (underneath), then draws without a verdict, then the failures on top."""
    if outcome in (OUTCOME_SUCCESS, SUCCESS_LATE):
        return 0
    if outcome == IMPOSSIBLE or "refused" in outcome:
        return 1
    return 2 if outcome in ("interrupted", "not run", "no result") else 3


def draw_map(table: pd.DataFrame, scene: dict | None, path: Path) -> Path | None:
    """The map of the draws at `path` (PNG), one panel per grid point; None when no varied field is a position."""
    fields = positional_fields(table)
    if not fields:
        return None
    table = table.assign(outcome=table["outcome"].fillna("no result").astype(str))
    colours = outcome_colours(table["outcome"])
    points = list(dict.fromkeys(table["point"])) if "point" in table else [None]
    columns = 1 if len(points) == 1 else 2
    rows = -(-len(points) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(11 * columns, 5.5 * rows), squeeze=False)
    for ax in axes.ravel()[len(points) :]:
        ax.axis("off")
    for ax, point in zip(axes.ravel(), points, strict=False):
        runs = table if point is None else table[table["point"] == point]
        _draw_scene(ax, scene or {}, fields)
        for outcome, group in sorted(runs.groupby("outcome"), key=lambda item: _rank(str(item[0]))):
            _draw_runs(ax, group, fields, scene or {}, colours[str(outcome)], 2 + _rank(str(outcome)))
        _label_failures(ax, runs, fields, scene or {})
        _legends(ax, runs["outcome"].value_counts(), colours, _kind_handles(fields, scene or {}))
        ax.set_aspect("equal")
        ax.margins(0.04)
        ax.set(xlabel="x [m]", ylabel="y [m]")
        ax.grid(alpha=0.3)
        where = f"grid point {point}: " if len(points) > 1 else ""
        ax.set_title(f"{where}{len(runs)} draws in plan view, coloured by the run's outcome", fontsize=10)
    save(fig, path)
    return path


def _legends(ax, counts: pd.Series, colours: dict[str, str], kinds: list[Line2D]) -> None:
    """Right of the panel: the outcomes with their run counts (the axes' legend), and the key to the markers."""
    ax.add_artist(ax.legend(handles=kinds, loc="lower left", bbox_to_anchor=(1.01, 0.0), fontsize=7))
    order = sorted(counts.index, key=lambda o: (_rank(str(o)) != 0, -counts[o], str(o)))
    handles = [Patch(color=colours[str(o)], label=f"{o} ({counts[o]})") for o in order]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="outcome (runs)")


def _values(runs: pd.DataFrame, field: str, components: dict[int, str], scene: dict) -> np.ndarray:
    """(runs, 3): a positional field per run, each component not varied from the scene (NaN without one)."""
    base = _at(scene, field)
    out = np.full((len(runs), 3), np.nan)
    for axis in range(3):
        if axis in components:
            out[:, axis] = pd.to_numeric(runs[components[axis]], errors="coerce").to_numpy(dtype=float)
        elif isinstance(base, list | tuple) and len(base) > axis:
            out[:, axis] = float(base[axis])
    return out


def _at(scene: dict, key: str) -> Any:
    try:
        return value_at(scene, key)
    except (KeyError, ValueError, IndexError, TypeError):
        return None


def _draw_runs(ax, runs: pd.DataFrame, fields: dict[str, dict[int, str]], scene: dict, colour: str, z: int) -> None:
    """One outcome's draws: starts with heading ticks, boxes, obstacle outlines and any other varied position."""
    alpha, width = (0.4, 0.7) if z == 2 else (0.95, 1.3)  # many successes faint, the few failures bold
    for field, components in fields.items():
        xyz = _values(runs, field, components, scene)
        if field.endswith("base_pose"):
            yaw = np.nan_to_num(np.radians(xyz[:, 2]))  # no yaw anywhere: facing +x
            ax.scatter(xyz[:, 0], xyz[:, 1], s=14, color=colour, alpha=alpha, zorder=z, linewidths=0)
            tips = xyz[:, :2] + HEADING_M * np.column_stack([np.cos(yaw), np.sin(yaw)])
            for (x0, y0), (x1, y1) in zip(xyz[:, :2], tips, strict=True):
                ax.plot([x0, x1], [y0, y1], color=colour, alpha=alpha, lw=width, zorder=z)
        elif field == "world.box.position":
            ax.scatter(xyz[:, 0], xyz[:, 1], s=22, marker="s", color=colour, alpha=alpha, zorder=z, linewidths=0)
        elif field.startswith("world.obstacles."):
            obstacle = _at(scene, field.removesuffix(".position"))
            ax.scatter(xyz[:, 0], xyz[:, 1], s=8, marker="x", color=colour, alpha=alpha, zorder=z, linewidths=0.8)
            for x, y, _ in xyz:
                if isinstance(obstacle, dict) and np.isfinite([x, y]).all():
                    outline = _outline(obstacle, (x, y), fill=False, ec=colour, lw=width, alpha=alpha * 0.8, zorder=z)
                    ax.add_patch(outline)
        else:
            ax.scatter(xyz[:, 0], xyz[:, 1], s=16, marker="D", color=colour, alpha=alpha, zorder=z, linewidths=0)


def _label_failures(ax, runs: pd.DataFrame, fields: dict[str, dict[int, str]], scene: dict) -> None:
    """The sample number at each drawn item of a run that did not succeed, when there are few of them."""
    failed = runs[runs["outcome"] != "success"]
    if not len(failed) or len(failed) > LABELLED or "sample" not in failed:
        return
    for field, components in fields.items():
        xyz = _values(failed, field, components, scene)
        for sample, (x, y, _) in zip(failed["sample"], xyz, strict=True):
            if np.isfinite([x, y]).all():
                ax.annotate(f"s{sample}", (x, y), xytext=(3, 3), textcoords="offset points", fontsize=6, zorder=7)


def _outline(obstacle: dict, centre: tuple[float, float], **style) -> Patch:
    """An obstacle's plan-view outline: a circle for a cylinder or sphere, a turned rectangle for a box."""
    size = obstacle.get("size") or (0.1, 0.1, 0.1)
    if obstacle.get("shape") in ("cylinder", "sphere"):
        return Circle(centre, float(size[0]) / 2, **style)
    return Polygon(_rectangle(centre, (float(size[0]), float(size[1])), obstacle.get("yaw_deg", 0.0)), **style)


def _rectangle(centre, size, yaw_deg: float) -> np.ndarray:
    """The corners of a rectangle of `size` (x, y) about `centre`, turned by `yaw_deg`."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    half = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.asarray(size[:2], dtype=float) / 2
    return np.asarray(centre[:2], dtype=float) + half @ np.array([[c, s], [-s, c]])


def _draw_scene(ax, scene: dict, fields: dict[str, dict[int, str]]) -> None:
    """The fixed scene, faint: tables, obstacles at their base positions, the box unless varied, its goal, the
    robot's start unless varied."""
    world = scene.get("world") or {}
    for table in world.get("tables") or []:
        corners = _rectangle(table["position"], table.get("top", (1.5, 0.8)), table.get("yaw_deg", 0.0))
        ax.add_patch(Polygon(corners, fc="0.88", ec="0.55", lw=1.0, zorder=1))
        below = (table["position"][0], corners[:, 1].min())  # the name under the table, clear of what is on it
        ax.annotate(table["name"], below, xytext=(0, -3), textcoords="offset points", ha="center", va="top", fontsize=7)
    for obstacle in world.get("obstacles") or []:
        centre = tuple(obstacle["position"][:2])
        ax.add_patch(_outline(obstacle, centre, fc="0.93", ec="0.6", ls="--", lw=0.8, zorder=1))
        ax.annotate(obstacle["name"], centre, ha="center", va="center", fontsize=7, color="0.5", zorder=1)
    box = world.get("box")
    if box and "world.box.position" not in fields:
        ax.add_patch(Polygon(_rectangle(box["position"], box["size"], box.get("yaw_deg", 0.0)), fc="0.6", zorder=1))
    if box and box.get("goal"):
        goal = box["goal"]
        ax.add_patch(Polygon(_rectangle(goal, box["size"], 0.0), fill=False, ec="k", ls=":", lw=1.0, zorder=6))
        below = (goal[0], goal[1] - box["size"][1] / 2)
        ax.annotate("box goal", below, xytext=(0, -2), textcoords="offset points", ha="center", va="top", fontsize=7)
    start = (scene.get("robot") or {}).get("base_pose")
    if start and not any(f.endswith("base_pose") for f in fields):
        yaw = math.radians(start[2])
        tip = (start[0] + HEADING_M * math.cos(yaw), start[1] + HEADING_M * math.sin(yaw))
        ax.plot([start[0], tip[0]], [start[1], tip[1]], color="0.4", zorder=1)
        ax.plot(start[0], start[1], "o", color="0.4", zorder=1)


def _kind_handles(fields: dict[str, dict[int, str]], scene: dict) -> list[Line2D]:
    """The key to the draws' markers, one entry per drawn field."""
    handles = []
    for field in fields:
        if field.endswith("base_pose"):
            handles.append(Line2D([], [], color="k", marker="o", markersize=4, label="robot start (heading)"))
        elif field == "world.box.position":
            handles.append(Line2D([], [], color="k", marker="s", ls="", markersize=4, label="box"))
        elif field.startswith("world.obstacles."):
            name = field.removeprefix("world.obstacles.").removesuffix(".position")
            obstacle = _at(scene, field.removesuffix(".position"))
            shape = obstacle.get("shape", "obstacle") if isinstance(obstacle, dict) else "obstacle"
            marker = "o" if shape in ("cylinder", "sphere") else "s"
            label = name if name == shape else f"{name} ({shape})"
            handles.append(Line2D([], [], color="k", marker=marker, mfc="none", ls="", markersize=8, label=label))
        else:
            handles.append(Line2D([], [], color="k", marker="D", ls="", markersize=4, label=field))
    return handles
