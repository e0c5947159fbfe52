"""Initial guesses of the task-space planner's SQP at a phase start: the straight line to the goal, and, when the
local SQP cannot go around an obstacle from it, the same curves moved onto a planar route around the obstacles
(route.py) — the SQP then refines a path on the route's side of every obstacle instead of looking for one.

Both are (7, M) Bezier control points: hand 0 xyz, hand 1 xyz, heading. The route moves both hands together (the
midpoint follows the route, the grip and the heading stay the straight line's), so the grip width is kept."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.mpc.route import Route, footprint, plan_route

if TYPE_CHECKING:
    from harmony_cli.mpc.hand_plan import Obstacle


def straight_line(start: np.ndarray, end: np.ndarray, M: int) -> np.ndarray:
    """Control points evenly along start -> end (7,): the curves move at constant speed."""
    return start[:, None] + (end - start)[:, None] * np.linspace(0, 1, M)


@dataclass(frozen=True)
class Ground:
    """What the base, which follows the hands, must keep clear of on the floor: the tables' outlines (`tables`,
    each with the base's margin) and every standing obstacle, by the base's half width `base_radius`."""

    tables: list[tuple[Shape, float]]
    base_radius: float


def route_around(
    obstacles: list[Obstacle],
    start: np.ndarray,
    goal: np.ndarray,
    carried: tuple[float, float] | None,
    ground: Ground | None = None,
) -> Route | None:
    """The hands' midpoint's planar route from `start` to `goal` (both (2, 3): the hands), clear of every static
    obstacle whose height overlaps the hands' (and the carried object's) by its clearance plus the larger of half
    the grip and the object's radius, so both hands and the object pass on the same side. With `ground`, also
    clear of the tables and of every obstacle from the floor up by the base's half width: the base follows the
    hands, so a route it cannot follow is no route. Moving obstacles are left to the local SQP (the route is for
    where things stand)."""
    hands_z = np.r_[start[:, 2], goal[:, 2]]
    low = 0.0 if ground is not None else hands_z.min() - (carried[1] if carried else 0.0)
    reach = max(0.5 * float(np.linalg.norm(goal[1] - goal[0])), carried[0] if carried else 0.0)
    if ground is not None:
        reach = max(reach, ground.base_radius)
    outlines = []
    for obstacle in obstacles:
        shape = obstacle.shape
        if obstacle.motion is not None:
            continue
        top, bottom = shape.centre[2] + shape.half[2], shape.centre[2] - shape.half[2]
        if top + obstacle.clearance < low or bottom - obstacle.clearance > hands_z.max():
            continue
        outlines.append(footprint(shape, obstacle.clearance + reach))
    if ground is not None:
        outlines += [footprint(table, margin + ground.base_radius) for table, margin in ground.tables]
    return plan_route(start.mean(axis=0)[:2], goal.mean(axis=0)[:2], outlines)


def moved_onto(C: np.ndarray, route: Route, basis: np.ndarray, s: np.ndarray, free: np.ndarray) -> np.ndarray:
    """`C` (straight-line control points) with both hands' free columns moved so that their midpoint follows
    `route` at the sample parameters `s` (least squares through `basis` (len(s), M)); fixed columns stay."""
    midpoint = 0.5 * (C[0:2] + C[3:5]) @ basis.T  # (2, S) the straight line's midpoint at the samples
    shift = route.at(s).T - midpoint
    columns = free[0]
    fitted = np.linalg.lstsq(basis[:, columns], shift.T, rcond=None)[0]  # (free columns, 2)
    moved = C.copy()
    moved[0:2, columns] += fitted.T
    moved[3:5, columns] += fitted.T
    return moved
