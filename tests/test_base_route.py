"""The planner's route as the base's while the box is held (plan_seed._base_route) against the shapes' own
distances."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.hand_plan import Obstacle
from harmony_cli.planning.plan_seed import Ground, route_around

BEHIND = np.array([-0.65, 0.0])  # the footprint's middle from the hands' midpoint, base frame
HALF_WIDTH = 0.38
BOX = (0.21, 0.15)  # a held box: its radius and its bottom below the hands [m]
POST = Shape("cylinder", np.array([1.5, -0.9, 1.0]), 0.0, np.array([0.2, 0.2, 1.0]))


def _rot2(angle: float) -> np.ndarray:
    return rot_z(np.asarray(angle))[:2, :2]


def _hands(x: float, y: float, heading: float) -> np.ndarray:
    """Two hands 0.3 m apart at (x, y, 1.3), across the heading (base yaw = heading here)."""
    across = _rot2(heading) @ np.array([0.0, 0.15])
    return np.array([[x + across[0], y + across[1], 1.3], [x - across[0], y - across[1], 1.3]])


def test_the_bases_route_keeps_the_footprint_clear_of_a_post_the_hands_straight_line_would_clear():
    # the base stands 0.65 m behind the hands, which face +y and move along x: the post is 0.9 m from the hands'
    # line (clear of it by its margin plus the base's half width) but 0.25 m from the base's
    ground = Ground([], HALF_WIDTH, BEHIND, 0.0)
    start, goal = _hands(0.0, 0.0, np.pi / 2), _hands(3.0, 0.0, np.pi / 2)
    found = route_around([Obstacle(POST, 0.1)], start, goal, BOX, ground, None, (np.pi / 2, np.pi / 2))
    assert found is not None and len(found.points) > 2
    hub = found.points + _rot2(np.pi / 2) @ BEHIND  # the heading stays: the base rides 0.65 m behind each point
    dense = np.vstack([np.linspace(a, b, 50) for a, b in zip(hub[:-1], hub[1:])])
    clearance = POST.distance(np.column_stack([dense, np.full(len(dense), 1.0)]))[0].min()
    assert clearance >= 0.1 + HALF_WIDTH - 1e-6
    assert np.allclose(found.points[[0, -1]], [start.mean(axis=0)[:2], goal.mean(axis=0)[:2]])


def test_with_free_hands_the_route_stays_the_midpoints_which_passes_that_post():
    ground = Ground([], HALF_WIDTH, BEHIND, 0.0)
    start, goal = _hands(0.0, 0.0, np.pi / 2), _hands(3.0, 0.0, np.pi / 2)
    found = route_around([Obstacle(POST, 0.1)], start, goal, None, ground, None, (np.pi / 2, np.pi / 2))
    assert found is not None and len(found.points) == 2


def test_with_nothing_in_the_way_the_bases_route_is_the_hands_straight_line():
    ground = Ground([], HALF_WIDTH, BEHIND, 0.0)
    start, goal = _hands(0.0, 0.0, 0.0), _hands(3.0, 1.0, 0.4)
    found = route_around([], start, goal, BOX, ground, None, (0.0, 0.4))
    assert found is not None and np.allclose(found.points, [start.mean(axis=0)[:2], goal.mean(axis=0)[:2]])
