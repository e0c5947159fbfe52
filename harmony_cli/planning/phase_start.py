"""How the task-space planner gets a phase's first plan: the SQP from the straight line, and where that plan is not
clean (not converged, short of a clearance, the hands split round an obstacle) the SQP from the line moved onto a
planar route round the obstacles (global guidance). Every QP is feasible (the clearance rows' slack, the horizon
from the rate bounds), so the only question is which seed: a route's SQP runs on the step after the line's, not on
the same step (both on one step would set the loop's slowest steps), or at once when the line's QP failed, or when
the phase has a point to pass (planner.py)."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from harmony_cli.planning.plan_checks import is_clean, rank
from harmony_cli.planning.plan_seed import fix_ends, on_route, straight_to

if TYPE_CHECKING:
    from harmony_cli.planning.hand_plan import Ends, Solved
    from harmony_cli.planning.hand_sqp import HandSQP
    from harmony_cli.planning.plan_seed import Ground


def on_route_plan(sqp: HandSQP, ground: Ground | None, t: float, T: float, ends: Ends, carried, width, via=None):
    """The SQP from the straight line moved onto a planar route (plan_seed.py) through `via` (2,) if given; None
    when there is no way round, or nothing in the way."""
    C = straight_to(ends, sqp.M)
    fix_ends(C, *ends, T)
    moved = on_route(C, ends, sqp.obstacles, carried, ground, via, (sqp.B, sqp.s, sqp.free, sqp.fit))
    if moved is None:
        return None
    return replace(sqp.solve(moved, t, T, ends, sqp.spec.phase_iterations, carried, width), routed=True)


def first_plan(
    sqp: HandSQP, ground: Ground | None, C, t: float, T: float, ends: Ends, how: tuple, fresh: bool
) -> tuple[Solved, bool]:
    """The SQP from `C` (the straight line on a phase's first step, `fresh`; else the last plan shifted) with
    `how` = (iterations, carried, width), and whether the next step should try a route: a fresh plan that is not
    clean asks for one; when its QP failed, the route is tried at once and taken if it ranks higher. (Not after
    any plan that is not clean: a line the SQP bends round a moving obstacle would be taken off it.)"""
    iterations, carried, width = how
    solved = sqp.solve(C, t, T, ends, iterations, carried, width)
    if not fresh or not sqp.obstacles or is_clean(solved, sqp.B, sqp.obstacles):
        return solved, False
    if solved.success:
        return solved, True
    routed = on_route_plan(sqp, ground, t, T, ends, carried, width)
    if routed is None or rank(routed, sqp.B, sqp.obstacles) <= rank(solved, sqp.B, sqp.obstacles):
        return solved, False
    return routed, False
