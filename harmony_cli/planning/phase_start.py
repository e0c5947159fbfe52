"""How the task-space planner gets a phase's first plan: the SQP from the straight line, and where that plan is not
clean (not converged, short of a clearance, the hands split round an obstacle) the SQP from the line moved onto a
planar route round the obstacles (global guidance). Every QP is feasible (the clearance rows' slack, the horizon
from the rate bounds), so the only question is which seed.

A first plan's SQP may take `phase_iterations` QPs, at most `step_iterations` of them on one control step: the
rest continue on the next steps from the plan so far (shifted to now, like a real-time iteration), which the hands
track meanwhile. Whether it wants a route is decided when it ends (converged, or its iterations spent); the route's
SQP then starts on the next step, or at once when the line's QP failed, or on the phase's first step when it has a
point to pass (planner.py). Bounding a step's work is what keeps the loop's slowest steps near its median."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from harmony_cli.planning.plan_checks import is_clean, rank
from harmony_cli.planning.plan_seed import fix_ends, on_route, straight_to

if TYPE_CHECKING:
    from harmony_cli.planning.hand_plan import Ends, Solved
    from harmony_cli.planning.hand_sqp import HandSQP
    from harmony_cli.planning.plan_seed import Ground


@dataclass
class FirstPlan:
    """A phase's first plan while its SQP runs: the iterations it may still take, and whether it was seeded on a
    route (a route's plan ends without asking for another)."""

    left: int
    routed: bool = False

    def take(self, most: int) -> int:
        """The iterations of this step's share (at most `most`), taken from what is left."""
        share = min(most, self.left)
        self.left -= share
        return share


def on_route_plan(
    sqp: HandSQP, ground: Ground | None, t: float, T: float, ends: Ends, carried, width, iterations: int, via=None
):
    """The SQP (`iterations` QPs at most) from the straight line moved onto a planar route (plan_seed.py) through
    `via` (2,) if given; None when there is no way round, or nothing in the way."""
    C = straight_to(ends, sqp.M)
    fix_ends(C, *ends, T)
    moved = on_route(C, ends, sqp.obstacles, carried, ground, via, (sqp.B, sqp.s, sqp.free, sqp.fit))
    if moved is None:
        return None
    return replace(sqp.solve(moved, t, T, ends, iterations, carried, width), routed=True)


def first_plan(
    sqp: HandSQP, ground: Ground | None, C, t: float, T: float, ends: Ends, how: tuple, first: FirstPlan | None
) -> tuple[Solved, bool]:
    """The SQP from `C` (the straight line on a phase's first step, else the last plan shifted) with `how` =
    (iterations, carried, width), and whether the next step should try a route. `first`: the phase's first plan
    this SQP continues (None: a later plan). A first plan from the line that ends not clean asks for a route; when
    its QP failed, the route is tried at once and taken if it ranks higher. (Not after any plan that is not clean:
    a line the SQP bends round a moving obstacle would be taken off it.)"""
    iterations, carried, width = how
    solved = sqp.solve(C, t, T, ends, iterations, carried, width)
    if first is not None and first.routed:
        return replace(solved, routed=True), False
    ends_now = not solved.success or solved.converged or (first is not None and first.left == 0)
    if first is None or not ends_now or not sqp.obstacles or is_clean(solved, sqp.B, sqp.obstacles):
        return solved, False
    if solved.success:
        return solved, True
    route = FirstPlan(sqp.spec.phase_iterations, routed=True)
    routed = on_route_plan(sqp, ground, t, T, ends, carried, width, route.take(sqp.spec.step_iterations))
    if routed is None or rank(routed, sqp.B, sqp.obstacles) <= rank(solved, sqp.B, sqp.obstacles):
        return solved, False
    first.left, first.routed = route.left, True
    return routed, False
