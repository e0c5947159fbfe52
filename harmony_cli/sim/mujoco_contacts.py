"""MuJoCo's contacts read as sim/touches.py and sim/contacts.py read PyBullet's: the contacts a task must not make
(the robot with a table or an obstacle, the box with an obstacle; the deepest per body over the physics steps since
the last control step) and the box's contacts with each hand's pads (the same PadContacts).

A contact of data.contact counts when its distance is <= 0 (with MuJoCo's default margin 0 all of them). Its frame's
rows are the normal (from geom1 to geom2) and two tangents; mj_contactForce gives the force in that frame."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.sim.contacts import PadContacts

if TYPE_CHECKING:
    from collections.abc import Sequence

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
    """The box's contacts with the robot as PadContacts: per hand (the bodies below its wrist sensor), its pads'
    contact points, their normal forces summed [N], |their summed friction force| / (friction x that sum) and the
    largest angle of a contact normal from the box's nearest face normal [deg]; beside them the normal force on
    robot bodies of no hand and those bodies (MuJoCo body ids). `friction`: the pad-box coefficient."""
    model, data, box = world.model, world.data, world.box
    n_hands = len(tool_bodies_per_hand)
    hands_of_body: dict[int, list[int]] = {}
    for h, bodies in enumerate(tool_bodies_per_hand):
        for b in bodies:
            hands_of_body.setdefault(b, []).append(h)
    points = np.zeros(n_hands, dtype=int)
    normal, force = np.zeros(n_hands), np.zeros((n_hands, 3))
    off = np.full(n_hands, np.nan)
    other, others = 0.0, set()
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.roll(world.box_state()[2], 1))
    box_rotation, wrench = rotation.reshape(3, 3), np.zeros(6)
    for i in range(data.ncon):
        contact = data.contact[i]
        b1, b2 = (int(model.geom_bodyid[g]) for g in contact.geom)
        robot_body = b2 if b1 == box else b1 if b2 == box else None
        if robot_body not in robot_bodies or contact.dist > 0.0:
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        frame = contact.frame.reshape(3, 3)
        if robot_body not in hands_of_body:
            other += wrench[0]
            others.add(robot_body)
            continue
        # a face's normal is a column of the box's rotation: the largest |cosine| is the nearest face
        angle = float(np.degrees(np.arccos(min(1.0, float(np.abs(box_rotation.T @ frame[0]).max())))))
        for h in hands_of_body[robot_body]:
            points[h] += 1
            normal[h] += wrench[0]
            force[h] += wrench[1] * frame[1] + wrench[2] * frame[2]
            off[h] = angle if np.isnan(off[h]) else max(off[h], angle)
    pressing = normal > 0.0
    used = np.full(n_hands, np.nan)
    used[pressing] = np.linalg.norm(force[pressing], axis=1) / (friction * normal[pressing])
    return PadContacts(points, normal, used, off, float(other), tuple(sorted(others)))
