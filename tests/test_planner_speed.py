"""The planner's QP inputs are written in place into buffers that outlive a step: what one step wrote must not leak
into the next."""

from __future__ import annotations

import numpy as np
import pytest

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Obstacle
from harmony_cli.scenario import PlannerSpec

SPEC = PlannerSpec()
HOME = np.stack([np.eye(3), np.eye(3)])
START = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
GOAL = START + [2.0, 0.0, 0.0]
CYLINDER = Obstacle(Shape("cylinder", np.array([1.7, -0.2, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), 0.13)


@pytest.mark.parametrize("before, after", [(0.2, None), (None, 0.2)], ids=["carried-then-not", "not-then-carried"])
def test_a_phase_plans_the_same_whatever_the_planner_solved_before(before, after):
    state = HandState(START, np.zeros((2, 3)), 0.0)
    used = HandMPC(SPEC, [CYLINDER], HOME, np.pi / 2)
    used.step(0.0, state, GOAL, 5.0, 0, before)
    fresh = HandMPC(SPEC, [CYLINDER], HOME, np.pi / 2)
    # a new phase starts from the straight line: nothing of the last plan is kept
    a, b = (p.step(0.0, state, GOAL, 5.0, 1, after) for p in (used, fresh))
    assert (a.success, a.status, a.iterations, a.min_clearance) == (b.success, b.status, b.iterations, b.min_clearance)
    np.testing.assert_array_equal(a.plan.control_points, b.plan.control_points)
