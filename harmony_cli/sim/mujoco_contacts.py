"""MuJoCo's contacts read as sim/touches.py and sim/contacts.py read PyBullet's: the contacts a task must not make
(the robot with a table or an obstacle, the box with an obstacle; the deepest per body over the physics steps since
the last control step) and the box's contacts with each hand's pads (the same PadContacts).

A contact of data.contact counts when its distance is <= 0 (with MuJoCo's default margin 0 all of them). Its frame's
rows are the normal (from geom1 to geom2) and two tangents; mj_contactForce gives the force in that frame."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.sim.contacts import ContactPoint, PadContacts, summarise

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from harmony_cli.sim.mujoco_world import MujocoWorld


class MujocoTouches:
    """Per table and obstacle the robot touched, and per obstacle the box touched, the deepest contact distance
    [m] (<= 0) over the physics steps since `clear`; bodies not touched are absent (as sim/touches.Touches)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, robot_bodies: set[int], world: MujocoWorld):
        self.model, self.data = model, data
        body_of = model.geom_bodyid
        self._robot_geom = np.isin(body_of, list(robot_bodies))
        tables = {name: {b} for name, b in world.tables.items()}
        obstacles = {name: {b} for name, b in world.obstacles.items()}
        # geom -> the name of the table or obstacle it belongs to
        self.robot_names = {
            int(g): n for n, bs in (tables | obstacles).items() for g in np.flatnonzero(np.isin(body_of, list(bs)))
        }
        self._box_geom = np.zeros(model.ngeom, dtype=bool)
        self.box_names: dict[int, str] = {}
        if world.box is not None:
            self._box_geom = body_of == world.box
            self.box_names = {g: n for g, n in self.robot_names.items() if n in obstacles}
        self.robot_bodies = list(tables) + list(obstacles)  # the names, in the scene's order
        self.box_bodies = list(obstacles) if world.box is not None else []
        self.robot_m: dict[str, float] = {}
        self.box_m: dict[str, float] = {}

    def clear(self) -> None:
        """Forget the touches seen so far (a new control step's physics steps begin)."""
        self.robot_m, self.box_m = {}, {}

    def after_physics_step(self) -> None:
        """Add this physics step's contacts (those mj_step found at the step's start)."""
        n = self.data.ncon
        if n == 0:
            return
        geoms, distances = self.data.contact.geom[:n], self.data.contact.dist[:n]
        for (g1, g2), distance in zip(geoms.tolist(), distances.tolist()):
            if distance > 0.0:
                continue
            for mine, other in ((g1, g2), (g2, g1)):
                if self._robot_geom[mine]:
                    _deepest(self.robot_names.get(other), distance, self.robot_m)
                elif self._box_geom[mine]:
                    _deepest(self.box_names.get(other), distance, self.box_m)


def _deepest(name: str | None, distance: float, deepest: dict[str, float]) -> None:
    """Into `deepest`: `distance` for `name` if it is the smallest yet."""
    if name is not None and distance < deepest.get(name, 1.0):
        deepest[name] = distance


def mujoco_pad_contacts(
    world: MujocoWorld,
    tool_bodies_per_hand: Sequence[set[int]],
    robot_bodies: set[int],
    friction: float,
) -> PadContacts:
    """The box's contacts with the robot (touching or inside) summarised as sim/contacts.py does for PyBullet: per
    hand (the bodies below its wrist sensor) its pads' points, forces, friction used and normals' angle off the box's
    faces; beside them the robot bodies of no hand (MuJoCo body ids). `friction`: the pad-box coefficient."""
    model, data, box = world.model, world.data, world.box
    hands_of_body: dict[int, list[int]] = {}
    for h, bodies in enumerate(tool_bodies_per_hand):
        for b in bodies:
            hands_of_body.setdefault(b, []).append(h)
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.roll(world.box_state()[2], 1))
    return summarise(
        _box_contacts(model, data, box, robot_bodies),
        hands_of_body,
        len(tool_bodies_per_hand),
        rotation.reshape(3, 3),
        friction,
    )


def _box_contacts(
    model: mujoco.MjModel, data: mujoco.MjData, box: int | None, robot_bodies: set[int]
) -> Iterator[ContactPoint]:
    """The box's contacts with robot bodies as ContactPoints (normal and friction from mj_contactForce in the
    contact's frame: its rows are the normal and the two tangents)."""
    n = data.ncon
    if n == 0 or box is None:
        return
    bodies = model.geom_bodyid[data.contact.geom[:n]]
    others = np.where(bodies[:, 0] == box, bodies[:, 1], np.where(bodies[:, 1] == box, bodies[:, 0], -1))
    wrench, frames = np.zeros(6), data.contact.frame[:n].reshape(n, 3, 3)
    for i in np.flatnonzero((data.contact.dist[:n] <= 0.0) & (others >= 0)).tolist():
        robot_body = int(others[i])
        if robot_body not in robot_bodies:
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        frame = frames[i]
        yield ContactPoint(robot_body, frame[0].copy(), float(wrench[0]), wrench[1] * frame[1] + wrench[2] * frame[2])
