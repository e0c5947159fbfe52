"""A phase's first plan whose SQP runs over several control steps (planner.step_iterations)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Obstacle, Outcome
from harmony_cli.scenario import PlannerSpec

HOME = np.stack([np.eye(3), np.eye(3)])
OFFSET = np.pi / 2  # hand 0 at +y, hand 1 at -y: heading 0 faces +x
START = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
GOAL = START + [2.0, 0.0, 0.0]


def _cylinder(y: float) -> Obstacle:
    return Obstacle(Shape("cylinder", np.array([1.7, y, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), 0.13)


ARGS = (HandState(START, np.zeros((2, 3)), 0.0), GOAL, 5.0, 0)


def _counting(planner: HandMPC) -> list[int]:
    """The QPs each SQP solve of `planner` runs, appended as they return."""
    counts, solve = [], planner.sqp.solve

    def counted(*args, **kwargs):
        solved = solve(*args, **kwargs)
        counts.append(solved.iterations)
        return solved

    planner.sqp.solve = counted  # type: ignore[method-assign]
    return counts


def test_a_first_plan_spread_over_steps_from_one_state_converges_to_the_plan_solved_in_one_step():
    # at one time and state every step continues the same Gauss-Newton iterates: the same plan at the end
    beside = [_cylinder(0.5)]  # beside the straight line: seven QPs to converge
    whole = HandMPC(PlannerSpec(phase_iterations=30, step_iterations=30), beside, HOME, OFFSET).step(0.0, *ARGS)
    assert whole.outcome is Outcome.CONVERGED and whole.iterations > 4
    spread = HandMPC(PlannerSpec(phase_iterations=30, step_iterations=2), beside, HOME, OFFSET)
    counts = _counting(spread)
    steps = [spread.step(0.0, *ARGS) for _ in range(whole.iterations)]
    ended = next(i for i, s in enumerate(steps) if s.outcome is Outcome.CONVERGED)
    assert counts[: ended + 1] == [2] * ended + [whole.iterations - 2 * ended]
    np.testing.assert_allclose(steps[ended].plan.control_points, whole.plan.control_points, atol=1e-6)
    assert counts[ended + 1 :] == [1] * (len(steps) - ended - 1)  # then one real-time iteration a step


def test_a_route_starts_when_the_line_s_sqp_ends_and_the_hands_hold_still_until_the_route_s_plan_is_taken():
    planner = HandMPC(PlannerSpec(phase_iterations=6, step_iterations=2), [_cylinder(0.0)], HOME, OFFSET)
    counts = _counting(planner)
    carried = (0.2, 0.0)  # the box cannot pass the cylinder on the straight line: the line's plan falls short
    results, wanted = [], []
    for k in range(6):
        results.append(planner.step(0.02 * k, *ARGS, *carried))
        wanted.append(planner.awaiting is not None)
    # the line's SQP: 2 + 2 QPs, converged short of the cylinder, not taken; the route's: 2 + 2 + 2; then a
    # real-time iteration
    assert [r.outcome for r in results] == [Outcome.SEARCHING] * 4 + [Outcome.STEPPED] * 2
    assert results[1].shortfall > 0.05 and wanted == [False, True, False, False, False, False]
    assert counts == [2, 2, 2, 2, 2, 1] and [r.routed for r in results] == [False, False, True, True, True, False]
    for running in results[:4]:  # no plan taken before the route's: the hands hold where they are
        held = running.plan.sample(np.linspace(0.0, 5.0, 11))[0]
        np.testing.assert_allclose(held, np.broadcast_to(START, held.shape), atol=1e-12)
    assert results[4].plan.start == 0.08 and results[4].shortfall < 5e-3  # the route's, clear of the cylinder


def test_a_route_whose_qp_fails_leaves_the_line_s_plan_taken_as_of_its_own_step_and_stepped_on():
    planner = HandMPC(PlannerSpec(phase_iterations=6, step_iterations=6), [_cylinder(0.0)], HOME, OFFSET)
    carried = (0.2, 0.0)
    line = planner.step(0.0, *ARGS, *carried)
    assert line.outcome is Outcome.SEARCHING and planner.awaiting is not None
    solve, calls = planner.sqp.solve, []

    def route_fails(C, t, T, ends, iterations, *rest):
        solved = solve(C, t, T, ends, iterations, *rest)
        calls.append(iterations)
        return replace(solved, outcome=Outcome.FAILED) if len(calls) == 1 else solved

    planner.sqp.solve = route_fails  # type: ignore[method-assign]
    result = planner.step(0.02, *ARGS, *carried)
    assert calls == [6, 1]  # the route's SQP, then a real-time iteration of the line's plan from now on
    assert result.outcome is Outcome.STEPPED and not result.routed and result.plan.start == 0.02
    assert planner.t_plan == 0.02 and planner.awaiting is None
