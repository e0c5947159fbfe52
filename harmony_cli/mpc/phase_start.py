"""How the task-space planner gets a phase's first plan: the SQP from the straight line, and where that plan is not
clean (not converged, short of a clearance, the hands split round an obstacle) the SQP from the line moved onto a
planar route round the obstacles (global guidance). Every QP is feasible (the clearance rows' slack, the horizon
from the rate bounds), so the only question is which seed: a route's SQP runs on the step after the line's, not on
the same step (both on one step would set the loop's slowest steps), or at once when the line's QP failed, or when
the phase has a point to pass (planner.py)."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from harmony_cli.mpc.plan_checks import is_clean, rank
from harmony_cli.mpc.plan_seed import fix_ends, on_route, straight_to

if TYPE_CHECKING:
    from harmony_cli.mpc.hand_plan import Ends
    from harmony_cli.mpc.planner import TaskPlanner


def on_route_plan(planner: TaskPlanner, t: float, T: float, ends: Ends, carried, width: float, via=None):
    """The SQP from the straight line moved onto a planar route (plan_seed.py) through `via` (2,) if given; None
    when there is no way round, or nothing in the way."""
    C = straight_to(ends, planner.M)
    fix_ends(C, *ends, T)
    sampling = (planner.B, planner.s, planner.free, planner.fit)
    moved = on_route(C, ends, planner.obstacles, carried, planner.ground, via, sampling)
    if moved is None:
        return None
    return replace(planner._solve(moved, t, T, ends, planner.spec.phase_iterations, carried, width), routed=True)


def first_plan(planner: TaskPlanner, C, t: float, T: float, ends: Ends, iterations: int, carried, width, fresh):
    """The SQP from `C` (the straight line on a phase's first step, `fresh`; else the last plan shifted). A fresh
    plan that is not clean asks for a route on the next step; when its QP failed, the route is tried at once and
    taken if it ranks higher. (Not after any plan that is not clean: a line the SQP bends round a moving obstacle
    would be taken off it.)"""
    solved = planner._solve(C, t, T, ends, iterations, carried, width)
    obstacles = planner.obstacles
    if not fresh or not obstacles or is_clean(solved, planner.B, obstacles):
        return solved
    if solved.success:
        planner._route_next = True
        return solved
    routed = on_route_plan(planner, t, T, ends, carried, width)
    if routed is None:
        return solved
    return routed if rank(routed, planner.B, obstacles) > rank(solved, planner.B, obstacles) else solved
