"""How the task-space planner gets a phase's first plan: a search. The SQP from the straight line, and where that
plan is not clean (not converged, short of a clearance, the hands split round an obstacle) the SQP from the line moved
onto a planar route round the obstacles (global guidance). Every QP is feasible (the clearance rows' slack, the
horizon from the rate bounds), so the only question is which seed.

Each SQP may take `phase_iterations` QPs, at most `step_iterations` of them on one control step; it goes on from its
iterate on the next steps. An SQP that has not ended is not a plan: the hands track the last plan taken until it
ends (the last phase's, which ends at rest at its goal; before any, where they are), so that a held box never
follows a half-solved path. The line's plan is taken when its SQP ends clean; when it does not, a route's SQP starts
on the next step (on the same step when the line's QP failed), and the route's plan is taken when its QP does not
fail, else the line's; a phase with a point to pass (`via`: a base pose that works at a blocked stance,
planning/stance_pose.py) starts with the route through it. Bounding a step's
work keeps the loop's slowest steps near its median (hand_mpc.py)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.planning.hand_plan import SHORT
from harmony_cli.planning.plan_seed import fix_ends, moved_onto, route_around, straight_to

if TYPE_CHECKING:
    from harmony_cli.planning.hand_plan import Ends, Obstacle, Solved
    from harmony_cli.planning.hand_sqp import HandSQP
    from harmony_cli.planning.plan_seed import Ground


class Step(Enum):
    """How a search's step ended: its SQP goes on (the last plan is tracked), its result is the step's plan (taken
    when its QP did not fail), or the route failed and the line's plan was taken, to step on from now."""

    RUNNING = "running"
    ENDED = "ended"
    LINE_TAKEN = "line taken"


@dataclass(frozen=True)
class Awaiting:
    """A line's first plan that is not clean, solved at time `t`, while its route's SQP runs."""

    phase: int
    line: Solved
    t: float


@dataclass
class Search:
    """One SQP of a phase's first plan, running over control steps: its phase, its iterate (7, M), the time its
    plan ends, the QPs it may still take; whether it was seeded on a route, through a point to pass, and after
    which line's plan."""

    phase: int
    C: np.ndarray
    end: float
    left: int
    routed: bool = False
    via: bool = False
    line: Awaiting | None = None  # a route's: the line's plan it replaces (taken if the route's QP fails)


def route_seed(sqp: HandSQP, ground: Ground | None, T: float, ends: Ends, carried, via=None) -> np.ndarray | None:
    """The straight line over a horizon T moved onto a planar route from the measured hands to the goal through
    `via` (2,) if given (plan_seed.route_around); None when there is no way round, or nothing in the way."""
    state, goal, heading = ends
    route = route_around(sqp.obstacles, state.positions, goal, carried, ground, via, (state.heading, heading))
    if route is None or len(route.points) == 2:
        return None
    C = straight_to(ends, sqp.M)
    fix_ends(C, *ends, T)
    return moved_onto(C, route, sqp.B, sqp.s, sqp.free, sqp.fit)


BETWEEN = np.array([0.25, 0.5, 0.75])  # fractions of the way from hand 0 to hand 1 checked for an obstacle
CLEARANCE_SLACK = 5e-3  # [m] predicted clearance shortfall tolerated in a phase's first plan
BASE_SLACK = 0.02  # [m] the same for the base footprint (carried as at home: the arms may make up the rest)


def is_clean(solved: Solved, basis: np.ndarray, obstacles: list[Obstacle]) -> bool:
    """A phase's first plan that needs no second look: converged, its predicted clearances met (hands, and nearly
    the base's, no shortfall) and no standing obstacle between the hands at a sample (`basis`: (S, M); a local SQP
    may split them round one)."""
    if not solved.converged:
        return False
    curves = solved.C[:6] @ basis.T
    hands = curves.reshape(2, 3, -1).transpose(0, 2, 1)  # (hand, sample, xyz)
    between = (hands[0] + BETWEEN[:, None, None] * (hands[1] - hands[0])).reshape(-1, 3)
    for obstacle in obstacles:
        if obstacle.motion is None and obstacle.shape.distance(between)[0].min() < 0.0:
            return False
    clear = solved.clearance >= -CLEARANCE_SLACK and solved.shortfall <= SHORT
    return clear and solved.base_clearance >= -BASE_SLACK
