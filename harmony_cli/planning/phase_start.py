"""How the task-space planner gets a phase's first plan: a search. The SQP from the straight line, and where that
plan is not clean (not converged, short of a clearance, the hands split round an obstacle) the SQP from the line moved
onto a planar route round the obstacles (global guidance). Every QP is feasible (the clearance rows' slack, the
horizon from the rate bounds), so the only question is which seed.

Each SQP may take `phase_iterations` QPs, at most `step_iterations` of them on one control step; it goes on from its
iterate on the next steps. An SQP that has not ended is not a plan: the hands track the last plan taken until it
ends (the last phase's, which ends at rest at its goal; before any, where they are), so that a held box never
follows a half-solved path. The line's plan is taken when its SQP ends; a route's SQP starts on the next step when
that plan is not clean, or on the same step when the line's QP failed; a phase with a point to pass (`via`: a base
pose that works at a blocked stance, planning/stance_pose.py) starts with the route through it. Bounding a step's
work keeps the loop's slowest steps near its median (hand_mpc.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.planning.plan_seed import fix_ends, on_route, straight_to

if TYPE_CHECKING:
    from harmony_cli.planning.hand_plan import Ends
    from harmony_cli.planning.hand_sqp import HandSQP
    from harmony_cli.planning.plan_seed import Ground


@dataclass
class Search:
    """One SQP of a phase's first plan, running over control steps: its phase, its iterate (7, M), the time its
    plan ends, the QPs it may still take; whether it was seeded on a route, and through a point to pass."""

    phase: int
    C: np.ndarray
    end: float
    left: int
    routed: bool = False
    via: bool = False

    def take(self, most: int) -> int:
        """The QPs of this step's share (at most `most`), taken from what is left."""
        share = min(most, self.left)
        self.left -= share
        return share


def route_seed(sqp: HandSQP, ground: Ground | None, T: float, ends: Ends, carried, via=None) -> np.ndarray | None:
    """The straight line over a horizon T moved onto a planar route (plan_seed.py) through `via` (2,) if given;
    None when there is no way round, or nothing in the way."""
    C = straight_to(ends, sqp.M)
    fix_ends(C, *ends, T)
    return on_route(C, ends, sqp.obstacles, carried, ground, via, (sqp.B, sqp.s, sqp.free, sqp.fit))


def held(positions: np.ndarray, heading: float, M: int) -> np.ndarray:
    """Control points (7, M) of the hands held at `positions` (2, 3) and `heading`: a plan before any is taken."""
    return np.repeat(np.r_[positions.ravel(), heading][:, None], M, axis=1)
