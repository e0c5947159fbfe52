"""A free-handed phase's goal moved out of the obstacles' margins. A way-in or way-out phase (an approach, a
retreat: its hands neither hold the box nor work at it) is a staging pose the scenario writes relative to the
box; where the box is drawn near an obstacle, that pose can lie inside the obstacle's margin, where the whole-body
MPC's hard clearance rows never let a hand go: the phase waits out its time 0.1-0.3 m short and the base arrives
where the written pose put it, against the obstacle (in the randomised study, every run that failed this way). The
pair of hands is moved rigidly, in plan view, by the smallest shift that clears every standing obstacle."""

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
