"""How the task-space planner gets a phase's first plan when the straight line does not do: a longer horizon (the
rate bounds), relaxed clearance rows (a start inside a margin) and a route round the obstacles (global guidance),
each at a bounded cost per control step: a QP that fails costs as much as a few that solve, and a route's SQP runs
on the step after the straight line's instead of that plan's own step (after the line's first two QPs failed from a
clear start, that step holds the last plan), or at once when the phase has a point to pass (planner.py)."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.mpc.hand_plan import Solved
from harmony_cli.mpc.plan_checks import is_clean, rank, starts_clear
from harmony_cli.mpc.plan_seed import fix_ends, on_route, straight_to

if TYPE_CHECKING:
    from harmony_cli.mpc.hand_plan import Ends
    from harmony_cli.mpc.planner import TaskPlanner

STRETCHES = (1.0, 1.5, 2.25, 3.5, 5.0)  # horizon factors tried when the rate bounds cannot be met in time


def first_step(
    planner: TaskPlanner, C: np.ndarray, t: float, T: float, ends: Ends, carried, width, blocked=None, skip=0
):
    """The SQP's first step from `C` (the planner's _sqp_step output), the horizon's stretch and whether relaxed.
    The measured start may not allow reaching the goal at rest within the rate bounds by the phase's end (the hands
    lag, the phase is short): then the smallest stretch that works. Last, the clearance rows violated now (the hands
    inside a margin, linearisations that contradict) ask only not to get worse. When the first two fail and the
    longest fails too, the ones between are not tried. None when the first two fail and `blocked` (if given) says
    yes: the caller tries a route before the rest. `skip`: how many of the first two are known to fail already."""

    def attempt(stretch: float, relaxed: bool = False):
        fix_ends(C, *ends, T * stretch)
        return planner._sqp_step(C, t, T * stretch, carried, width, relaxed)

    for stretch in STRETCHES[skip:2]:  # the horizon as it is, then the stretch most starts need
        if (out := attempt(stretch))[0] is not None:
            return out, stretch, False
    if blocked is not None and blocked():
        return None
    tries = [(s, False) for s in STRETCHES[2:]] if attempt(STRETCHES[-1])[0] is not None else []
    relaxed = False
    for stretch, relaxed in tries + [(s, True) for s in STRETCHES]:
        out = attempt(stretch, relaxed)
        if out[0] is not None:
            break
    return out, stretch, relaxed


def on_route_plan(
    planner: TaskPlanner, solved: Solved | None, t: float, T: float, ends: Ends, carried, width: float, via=None
) -> Solved | None:
    """The SQP from the straight line moved onto a planar route (plan_seed.py) through `via` (2,) if given; taken
    if it ranks above `solved` (if any) or, through `via`, succeeds; `solved` when there is no route."""
    C = straight_to(ends, planner.M)
    fix_ends(C, *ends, T)
    sampling = (planner.B, planner.s, planner.free, planner.fit)
    moved = on_route(C, ends, planner.obstacles, carried, planner.ground, via, sampling)
    if moved is None:  # no way round, or nothing in the way: nothing to seed
        return solved
    seeded = planner._solve(moved, t, T, ends, planner.spec.phase_iterations, carried, width)
    seeded = replace(seeded, status=seeded.status + " (route)")
    if solved is None or (via is not None and seeded.success):
        return seeded
    return seeded if rank(seeded, planner.B, planner.obstacles) > rank(solved, planner.B, planner.obstacles) else solved


def first_plan(planner: TaskPlanner, C, t: float, T: float, ends: Ends, iterations: int, carried, width, fresh, now):
    """The SQP from the straight line `C`; None on a phase's first step where the horizon as it is and its usual
    stretch both fail from a clear start (an obstacle in the way, most likely) and there is a plan to hold: the
    caller holds it and asks for the route on the next step, so each step runs at most its two failing QPs or the
    route's SQP (both on one step would set the loop's slowest steps). With no plan yet (a run's first step) the
    route now, the line's other horizons if it fails. Otherwise a plan that is not clean asks for a route on the
    next step, a failed one tries it now. `now`: this step's route was tried already. A start inside a margin keeps
    the straight line's relaxed rows (never deeper), which a route would not. (The route is not tried after the
    first failure alone: a line the SQP can bend round a moving obstacle would be taken off it.)"""
    obstacles, blocked = planner.obstacles, None
    if fresh and obstacles and not now:

        def blocked() -> bool:
            return starts_clear(obstacles, ends[0].positions, t, planner._reliefs, carried)

    straight = planner._solve(C, t, T, ends, iterations, carried, width, blocked)
    if straight is None:
        if planner.C is not None:
            return None
        routed = on_route_plan(planner, None, t, T, ends, carried, width)
        if routed is not None and routed.success:
            return routed
        straight = planner._solve(C, t, T, ends, iterations, carried, width, skip=2)  # the rest of the line's ladder
        return straight if routed is None or straight.success else routed
    if fresh and straight.success and not now:
        planner._route_next = bool(obstacles) and not is_clean(straight, planner.B, obstacles)
    elif obstacles and not straight.success and not now:
        return on_route_plan(planner, straight, t, T, ends, carried, width) or straight
    return straight


def held_plan(planner: TaskPlanner) -> Solved:
    """The planner's last plan, held while the route of a blocked line is found on the next step (first_plan)."""
    assert planner.C is not None
    return Solved(planner.C, planner.T_plan, True, "line blocked: last plan held, route next step", 0, np.inf, 1.0)
