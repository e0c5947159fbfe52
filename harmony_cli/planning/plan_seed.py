"""Initial guesses of the task-space planner's SQP at a phase start: the straight line to the goal, and, when the
local SQP cannot go around an obstacle from it, the same curves moved onto a planar route around the obstacles
(route.py) — the SQP then refines a path on the route's side of every obstacle instead of looking for one.

Both are (7, M) Bezier control points: hand 0 xyz, hand 1 xyz, heading. The route moves both hands together (the
midpoint follows the route, the grip and the heading stay the straight line's), so the grip width is kept."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.route import Route, footprint, plan_route
from harmony_cli.planning.visibility import corner_graph, polygon_of

if TYPE_CHECKING:
    from harmony_cli.planning.hand_plan import HandState, Obstacle

ROUTE_POINTS = 41  # the base's route, read at this many even steps of its length, carries the midpoint


def straight_to(ends, M: int) -> np.ndarray:
    """Control points (7, M) evenly from the measured hands and heading to the goal's (`ends`: state, goal,
    heading): the curves move at constant speed."""
    state, goal, heading_goal = ends
    start = np.concatenate([state.positions.ravel(), [state.heading]])
    end = np.concatenate([goal.ravel(), [heading_goal]])
    return start[:, None] + (end - start)[:, None] * np.linspace(0, 1, M)


def fix_ends(C: np.ndarray, state: HandState, goal: np.ndarray, goal_heading: float, T: float) -> None:
    """`C`'s fixed columns, in place: the first two from the measured state (its velocity over a horizon `T`), the
    last three at the goal (at rest)."""
    n = C.shape[1] - 1  # in place, no concatenated (7,) vectors: the same floats, ~10 us less
    C[:6, 0], C[6, 0] = state.positions.ravel(), state.heading
    C[:6, 1], C[6, 1] = C[:6, 0] + state.velocities.ravel() * T / n, state.heading + state.heading_rate * T / n
    C[:6, -3:], C[6, -3:] = goal.reshape(6, 1), goal_heading


@dataclass(frozen=True)
class Ground:
    """What the base, which follows the hands, must keep clear of on the floor: the tables' outlines (`tables`,
    each with the base's margin) and every standing obstacle, by the base's half width `base_radius`. `behind`
    (2,): the footprint's middle from the hands' midpoint in the base frame as at home, the base's yaw there
    `yaw_home` (heading 0); None: the route is the midpoint's (no footprint model)."""

    tables: list[tuple[Shape, float]]
    base_radius: float
    behind: np.ndarray | None = None
    yaw_home: float = 0.0


def route_around(
    obstacles: list[Obstacle],
    start: np.ndarray,
    goal: np.ndarray,
    carried: tuple[float, float] | None,
    ground: Ground | None = None,
    via: np.ndarray | None = None,
    headings: tuple[float, float] | None = None,
) -> Route | None:
    """The hands' midpoint's planar route from `start` to `goal` (both (2, 3): the hands), clear of every static
    obstacle whose height overlaps the hands' (and the carried object's) by its clearance plus the larger of half
    the grip and the object's radius, so both hands and the object pass on the same side. With `ground`, also
    clear of the tables and of every obstacle from the floor up by the base's half width: the base follows the
    hands, so a route it cannot follow is no route; while the box is held (`carried`) and with the base's place
    behind the hands known (`ground.behind`) and the `headings` (start, goal), the route is the base's
    (_base_route) where the base has to go round something (else the midpoint's, which still takes the hands round
    what is in their way: the paper's static_obstacles slides the box round a crate on the table). Through a `via`
    (a blocked stance's base pose, stance_plan.py) it stays the midpoint's: the via is a pose for the hands to
    pass, and the base's route through it placed boxes further from their goals. Moving obstacles are left to the
    local SQP (the route is for where things stand)."""
    if carried is not None and via is None and ground is not None and ground.behind is not None and headings:
        based = _base_route(obstacles, start, goal, ground, headings)
        if based is not None:
            return based
    hands_z = np.r_[start[:, 2], goal[:, 2]]
    low = 0.0 if ground is not None else hands_z.min() - (carried[1] if carried else 0.0)
    reach = max(0.5 * float(np.linalg.norm(goal[1] - goal[0])), carried[0] if carried else 0.0)
    if ground is not None:
        reach = max(reach, ground.base_radius)
    outlines = _outlines(obstacles, ground, (low, hands_z.max()), reach)
    ends = start.mean(axis=0)[:2], goal.mean(axis=0)[:2]
    if via is None:
        return plan_route(*ends, outlines)
    legs = plan_route(ends[0], via, outlines), plan_route(via, ends[1], outlines)
    if legs[0] is None or legs[1] is None:
        return None
    return Route(np.vstack([legs[0].points, legs[1].points[1:]]), legs[0].length + legs[1].length)


def _outlines(obstacles: list[Obstacle], ground: Ground | None, band: tuple[float, float], grow: float) -> list:
    """The plan-view outlines of the static obstacles reaching into the height `band` (low, high), each grown by
    its clearance plus `grow`, then with `ground` the tables' grown by their margin plus the base's half width."""
    outlines = []
    for obstacle in obstacles:
        shape = obstacle.shape
        top, bottom = shape.centre[2] + shape.half[2], shape.centre[2] - shape.half[2]
        if obstacle.motion is None and top + obstacle.clearance >= band[0] and bottom - obstacle.clearance <= band[1]:
            outlines.append(footprint(shape, obstacle.clearance + grow))
    if ground is not None:
        outlines += [footprint(table, margin + ground.base_radius) for table, margin in ground.tables]
    return outlines


def _base_route(obstacles, start, goal, ground: Ground, headings: tuple[float, float]) -> Route | None:
    """While the box is held, the hands' midpoint's route as the base's: the footprint's middle routed from where it
    stands behind the hands at `start` to where it stands behind them at `goal`, clear of every static obstacle up
    to the hands by its clearance and of the tables by their margins, both plus the base's half width; the midpoint
    rides in front of it, the heading turning evenly from the start's to the goal's as the straight line's does
    (ROUTE_POINTS along it). Why: the base stands some 0.6 m behind the hands, and the midpoint's route can carry the
    box where the base cannot follow (out from between an obstacle and a table's corner, the whole-body MPC's base
    wedges between them, its clearance rows contradict at the horizon's end and a held box may be dropped)."""
    assert ground.behind is not None
    outlines = _outlines(obstacles, ground, (0.0, max(start[:, 2].max(), goal[:, 2].max())), ground.base_radius)
    behind = lambda heading: rot_z(np.asarray(ground.yaw_home + heading))[:2, :2] @ ground.behind  # noqa: E731
    ends = [hands.mean(axis=0)[:2] + behind(h) for hands, h in ((start, headings[0]), (goal, headings[1]))]
    route = plan_route(ends[0], ends[1], outlines)
    if route is None or len(route.points) == 2:  # no way round for the base, or none needed: the midpoint's route
        return None
    u = np.linspace(0.0, 1.0, ROUTE_POINTS)
    turns = headings[0] + (headings[1] - headings[0]) * u
    points = route.at(u) - np.array([behind(h) for h in turns])
    return Route(points, float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()))


def warm_outlines(obstacles: list[Obstacle], ground: Ground | None) -> None:
    """route_around's outlines of the static obstacles and the tables when the base's half width is the widest
    reach (EVA: 0.38 m against a 0.22 m box), their geometry for the visibility tests and the graph between their
    corners, made ahead (route.footprint, visibility.polygon_of and corner_graph keep them): a phase's first route,
    inside a control step, then finds them ready instead of making them in its step.
    Made for every static obstacle; a route at hands' heights that leave one out makes its own graph."""
    if ground is None:
        return
    corner_graph([polygon_of(o) for o in _outlines(obstacles, ground, (-np.inf, np.inf), ground.base_radius)])


def moved_onto(C: np.ndarray, route: Route, basis: np.ndarray, s: np.ndarray, free: np.ndarray, fit: np.ndarray):
    """`C` (straight-line control points) with both hands' free columns moved so that their midpoint follows
    `route` at the sample parameters `s` (least squares: `fit` (free columns, len(s)), the pseudo-inverse of
    `basis`'s free columns); fixed columns stay."""
    midpoint = 0.5 * (C[0:2] + C[3:5]) @ basis.T  # (2, S) the straight line's midpoint at the samples
    fitted = (route.at(s).T - midpoint) @ fit.T  # (2, free columns)
    columns = free[0]
    moved = C.copy()
    moved[0:2, columns] += fitted
    moved[3:5, columns] += fitted
    return moved
