"""What the planner asks of a phase's first plan before it takes it: the hands pass every obstacle on one side with
their clearance; and how far a phase's goal itself lies inside a clearance."""

from __future__ import annotations

import numpy as np

from harmony_cli.planning.hand_plan import SHORT, Obstacle, Solved

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


GOAL_INSIDE = 5e-3  # [m] how far inside the goal's own distance a lowered clearance is kept


def goal_reliefs(obstacles: list[Obstacle], goal: np.ndarray, end: float, carried: tuple[float, float] | None):
    """Per obstacle where it is at time `end`, how much its clearance must drop for the phase's `goal` (2, 3) hands
    and the object carried between them (its radius and drop below the hands) to meet it, plus GOAL_INSIDE (0
    where the goal is clear). An author may put a goal within an obstacle's margin (the margin is a preference, the
    obstacle is not): the plan still ends there and keeps as far away as the goal allows on its way; the whole-body
    MPC keeps its own margins."""
    reliefs = np.zeros(len(obstacles))
    for i, obstacle in enumerate(obstacles):
        moved = 0.0 if obstacle.motion is None else obstacle.motion(np.array([end]))[0] - obstacle.shape.centre
        margin = obstacle.shape.distance(goal - moved)[0].min() - obstacle.clearance
        if carried is not None:
            point = goal.mean(axis=0) - [0.0, 0.0, carried[1]]
            distance = obstacle.shape.grown(carried[0]).distance(point[None] - moved)[0][0]
            margin = min(margin, distance - obstacle.clearance)
        reliefs[i] = GOAL_INSIDE - margin if margin < 0.0 else 0.0
    return reliefs
