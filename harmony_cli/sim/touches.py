"""The contacts a task must not make: the robot (any link) with a table (its top or a leg) or an obstacle, and the
box with an obstacle, read from PyBullet's contact points after every physics step, so that a touch between two
control steps is seen too. A point counts when its distance is <= 0 (touching or inside; PyBullet also reports
points a little apart). What a task does by design is left out: the box on a table, the pads on the box."""

from __future__ import annotations

from operator import itemgetter
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

    from pybullet_utils.bullet_client import BulletClient

_body_b, _distance = itemgetter(2), itemgetter(8)  # of a contact point: the other body, signed distance [m]


class Touches:
    """Per table and obstacle the robot touched, and per obstacle the box touched, the deepest contact distance
    [m] (<= 0) over the physics steps since `clear`; bodies not touched are absent."""

    def __init__(
        self,
        client: BulletClient,
        robot: int,
        box: int | None,
        tables: dict[str, list[int]],
        obstacles: dict[str, int],
    ):
        self._contact_points = client.getContactPoints  # bound once (a BulletClient attribute is a new partial)
        self.robot, self.box = robot, box
        self.robot_names = {i: name for name, ids in tables.items() for i in ids}
        self.robot_names |= {i: name for name, i in obstacles.items()}
        self.box_names = {i: name for name, i in obstacles.items()} if box is not None else {}
        self.robot_bodies = list(tables) + list(obstacles)  # the names, in the scene's order
        self.box_bodies = list(obstacles) if box is not None else []
        self.robot_m: dict[str, float] = {}
        self.box_m: dict[str, float] = {}

    def clear(self) -> None:
        """Forget the touches seen so far (a new control step's physics steps begin)."""
        self.robot_m, self.box_m = {}, {}

    def after_physics_step(self) -> None:
        """Add this physics step's contacts: one query for the robot's, one for the box's."""
        if self.robot_names:
            _deepest(self._contact_points(bodyA=self.robot), self.robot_names, self.robot_m)
        if self.box_names:
            _deepest(self._contact_points(bodyA=self.box), self.box_names, self.box_m)


def _deepest(points: Sequence[tuple], names: dict[int, str], deepest: dict[str, float]) -> None:
    """Into `deepest`: per named body B, the smallest distance of the points with it that are <= 0."""
    for point in points:
        name = names.get(_body_b(point))
        if name is None:
            continue
        distance = _distance(point)
        if distance <= 0.0 and distance < deepest.get(name, 1.0):
            deepest[name] = distance
