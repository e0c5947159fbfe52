"""What the planner asks of a phase's first plan before it takes it (and ranks two plans by): the hands pass
every obstacle on one side with their clearance."""

from __future__ import annotations

import numpy as np

from harmony_cli.mpc.hand_plan import Obstacle, Solved

BETWEEN = np.array([0.25, 0.5, 0.75])  # fractions of the way from hand 0 to hand 1 checked for an obstacle
CLEARANCE_SLACK = 5e-3  # [m] predicted clearance shortfall tolerated in a phase's first plan


def keeps_shape(solved: Solved, basis: np.ndarray, obstacles: list[Obstacle]) -> bool:
    """Whether a plan passes every obstacle with both hands on one side: its predicted clearance is met and no
    standing obstacle is between the hands at a sample (`basis`: (S, M); a local SQP may split them round one)."""
    curves = solved.C[:6] @ basis.T
    hands = curves.reshape(2, 3, -1).transpose(0, 2, 1)  # (hand, sample, xyz)
    between = (hands[0] + BETWEEN[:, None, None] * (hands[1] - hands[0])).reshape(-1, 3)
    for obstacle in obstacles:
        if obstacle.motion is None and obstacle.shape.distance(between)[0].min() < 0.0:
            return False
    return solved.clearance >= -CLEARANCE_SLACK
