"""A free-handed phase's goal moved out of the obstacles' margins. A way-in or way-out phase (an approach, a
retreat: its hands neither hold the box nor work at it) is a staging pose the scenario writes relative to the
box; where the box is drawn near an obstacle, that pose can lie inside the obstacle's margin, where the whole-body
MPC's hard clearance rows never let a hand go: the phase waits out its time 0.1-0.3 m short and the base arrives
where the written pose put it, against the obstacle (in the randomised study, every run that failed this way). The
pair of hands is moved rigidly, in plan view, by the smallest shift that clears every standing obstacle. A goal
still inside a margin (another phase's, one no shift clears, a moving obstacle's) is kept: the task-space planner
lowers that obstacle's clearance to just below the goal's own distance (goal_reliefs)."""

from __future__ import annotations

import numpy as np

from harmony_cli.planning.hand_plan import Obstacle

STEP = 0.02  # [m] shifts tried: STEP, 2 STEP, ... up to FARTHEST, in DIRECTIONS directions about the vertical
FARTHEST = 1.0
DIRECTIONS = 36
SPARE = 0.01  # [m] past the margin: a goal on its edge is one a hand reaches only in the limit


def cleared(goal: np.ndarray, obstacles: list[Obstacle]) -> tuple[np.ndarray, float, int | None]:
    """The hands' `goal` (hands, 3) shifted clear of every obstacle that stands still (its clearance: margin +
    hand radius, and SPARE): the goal, how far it moved [m] and the index of the obstacle it was inside (None: not
    inside one; the goal as it is when no shift up to FARTHEST clears it)."""
    still = [k for k, o in enumerate(obstacles) if o.motion is None]
    inside = [k for k in still if (obstacles[k].shape.distance(goal)[0] < obstacles[k].clearance).any()]
    if not inside:
        return goal, 0.0, None
    radii = np.arange(1, int(round(FARTHEST / STEP)) + 1) * STEP
    angles = np.linspace(0.0, 2 * np.pi, DIRECTIONS, endpoint=False)
    shifts = (radii[:, None, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)[None]).reshape(-1, 2)
    moved = goal[None] + np.pad(shifts, ((0, 0), (0, 1)))[:, None]  # (shifts, hands, 3)
    points = moved.reshape(-1, 3)
    margin = np.min([obstacles[k].shape.distance(points)[0] - obstacles[k].clearance - SPARE for k in still], axis=0)
    worst = margin.reshape(len(shifts), -1).min(axis=1)  # each shift's hand nearest an obstacle
    ok = np.flatnonzero(worst >= 0.0)
    if not len(ok):
        return goal, 0.0, inside[0]
    first = ok[ok // DIRECTIONS == ok[0] // DIRECTIONS]  # the shortest clear shifts (shifts go ring by ring)
    best = first[np.argmax(worst[first])]
    return moved[best], float(np.hypot(*shifts[best])), inside[0]


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
