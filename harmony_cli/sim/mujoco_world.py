"""The scene of a scenario in MuJoCo: a ground plane, tables (top and legs, as sim/world.py builds them), the box as
a free body and obstacles (static bodies, moving ones mocap bodies), added to the robot's MjSpec before it is
compiled; then read back from the compiled model by name: `table:<name>` (geoms `table:<name>:top`,
`table:<name>:leg<i>`), `obstacle:<name>` (body and geom), `box` (body and geom), `ground`.
Contact parameters: sim/mujoco_contact_model.py."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.maths.shapes import table_legs
from harmony_cli.sim.mujoco_contact_model import BOX_PRIORITY, ROLLING, box_table_pairs, contact_options
from harmony_cli.sim.mujoco_contacts import mujoco_pad_contacts
from harmony_cli.tasks.motion import centre_at

if TYPE_CHECKING:
    from collections.abc import Sequence

    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import BoxSpec, ObstacleSpec, TableSpec, WorldSpec
    from harmony_cli.sim.contacts import PadContacts

FAR = 5.0  # [m] clearances beyond this are reported as FAR (as sim/world.py)
# the ground touches the box and the scene (contype / conaffinity 1) but not the robot (its geoms: 2 / 1), which
# stands on its virtual base joints: a foot or pedestal resting on the floor would otherwise press into it through
# the rigid chain and hold the base by friction
GROUND_CONTYPE, GROUND_CONAFFINITY = 0, 1
GEOM = mujoco.mjtGeom
_TABLE_RGBA, _OBSTACLE_RGBA, _BOX_RGBA = [0.55, 0.45, 0.35, 1], [0.7, 0.2, 0.2, 1], [0.85, 0.6, 0.3, 1]


def _quat(yaw_deg: float) -> list[float]:
    """MuJoCo's (w, x, y, z) quaternion of a turn by yaw about z."""
    half = np.deg2rad(yaw_deg) / 2
    return [float(np.cos(half)), 0.0, 0.0, float(np.sin(half))]


def add_world(spec: mujoco.MjSpec, world: WorldSpec | None, sim_spec: SimSpec) -> None:
    """Add the ground, and the scene of `world` if any, to `spec`; set `contact_options`."""
    contact_options(spec, sim_spec)
    spec.worldbody.add_geom(
        name="ground",
        type=GEOM.mjGEOM_PLANE,
        size=[0.0, 0.0, 1.0],
        rgba=[0.8, 0.8, 0.8, 1],
        contype=GROUND_CONTYPE,
        conaffinity=GROUND_CONAFFINITY,
    )
    if world is None:
        return
    for table in world.tables:
        _add_table(spec, table)
    for obstacle in world.obstacles:
        _add_obstacle(spec, obstacle)
    if world.box is not None:
        _add_box(spec, world.box)
        for table in world.tables:
            box_table_pairs(spec, world.box, table)


def _add_table(spec: mujoco.MjSpec, t: TableSpec) -> None:
    """A static body: the top (its upper surface at t.height) and four legs (maths.shapes.table_legs)."""
    body = spec.worldbody.add_body(name=f"table:{t.name}")
    friction = [t.friction, 0.0, ROLLING]
    body.add_geom(
        name=f"table:{t.name}:top",
        type=GEOM.mjGEOM_BOX,
        size=[t.top[0] / 2, t.top[1] / 2, t.thickness / 2],
        pos=[*t.position, t.height - t.thickness / 2],
        quat=_quat(t.yaw_deg),
        friction=friction,
        rgba=_TABLE_RGBA,
    )
    for i, leg in enumerate(table_legs(t)):
        body.add_geom(
            name=f"table:{t.name}:leg{i}",
            type=GEOM.mjGEOM_BOX,
            size=leg.half.tolist(),
            pos=leg.centre.tolist(),
            quat=_quat(t.yaw_deg),
            friction=friction,
            rgba=_TABLE_RGBA,
        )


def _add_obstacle(spec: mujoco.MjSpec, o: ObstacleSpec) -> None:
    """A static body (a mocap body when it moves) with one geom: MuJoCo's sizes are half extents, (radius, half
    height) of a cylinder, (radius,) of a sphere."""
    half = np.asarray(o.size, dtype=float) / 2
    body = spec.worldbody.add_body(
        name=f"obstacle:{o.name}", pos=list(o.position), quat=_quat(o.yaw_deg), mocap=o.motion is not None
    )
    kind, size = {
        "box": (GEOM.mjGEOM_BOX, half.tolist()),
        "cylinder": (GEOM.mjGEOM_CYLINDER, [half[0], half[2], 0.0]),
        "sphere": (GEOM.mjGEOM_SPHERE, [half[0], 0.0, 0.0]),
    }[o.shape]
    body.add_geom(name=f"obstacle:{o.name}", type=kind, size=size, rgba=_OBSTACLE_RGBA)


def _add_box(spec: mujoco.MjSpec, b: BoxSpec) -> None:
    """A free body of uniform density (inertia as sim/world.box_urdf); priority 1 (module docstring)."""
    x, y, z = (float(v) for v in b.size)
    body = spec.worldbody.add_body(name="box", pos=list(b.position), quat=_quat(b.yaw_deg))
    body.add_freejoint(name="box")
    body.explicitinertial = True
    body.mass, body.ipos, body.iquat = b.mass, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]  # else ipos copies pos
    body.inertia = [b.mass / 12.0 * (p * p + q * q) for p, q in ((y, z), (x, z), (x, y))]
    body.add_geom(
        name="box",
        type=GEOM.mjGEOM_BOX,
        size=[x / 2, y / 2, z / 2],
        friction=[b.friction, b.spinning_friction, ROLLING],
        priority=BOX_PRIORITY,
        condim=3,
        rgba=_BOX_RGBA,
    )


class MujocoWorld:
    """The compiled scene: tables, obstacles (moving ones by their motion) and the box, found by name."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, world: WorldSpec | None):
        self.model, self.data, self.spec = model, data, world
        body = lambda name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        self.tables: dict[str, int] = {t.name: body(f"table:{t.name}") for t in (world.tables if world else [])}
        obstacles = world.obstacles if world else []
        self.obstacles: dict[str, int] = {o.name: body(f"obstacle:{o.name}") for o in obstacles}
        self.obstacle_geoms = {name: _geoms_of(model, {b}) for name, b in self.obstacles.items()}
        self._geoms: dict[frozenset[int], list[int]] = {}
        self.moving = {o.name: o for o in obstacles if o.motion is not None}
        self._mocap = {name: int(model.body_mocapid[self.obstacles[name]]) for name in self.moving}
        self.box: int | None = body("box") if world is not None and world.box is not None else None
        self._box_qpos = None
        if self.box is not None:
            self._box_qpos = int(model.jnt_qposadr[model.body_jntadr[self.box]])
        self.move_obstacles(0.0)

    def move_obstacles(self, t: float) -> None:
        """Every moving obstacle to where its motion says at time t."""
        for name, o in self.moving.items():
            self.data.mocap_pos[self._mocap[name]] = centre_at(o, t)[0]

    def obstacle_position(self, name: str) -> np.ndarray:
        """An obstacle's centre as MuJoCo has it (a moving one's mocap position)."""
        if name in self._mocap:
            return self.data.mocap_pos[self._mocap[name]].copy()
        return self.model.body_pos[self.obstacles[name]].copy()

    def _box_qpos_now(self) -> tuple[np.ndarray, np.ndarray]:
        """The box's centre and (w, x, y, z) quaternion from its free joint (mj_step leaves xpos a step behind)."""
        assert self._box_qpos is not None, "no box in this world"
        q = self.data.qpos[self._box_qpos : self._box_qpos + 7]
        return q[:3].copy(), q[3:7] / np.linalg.norm(q[3:7])

    def place_box(self, centre: np.ndarray, quaternion_xyzw: np.ndarray) -> None:
        """The box where a log had it (centre, PyBullet's (x, y, z, w) quaternion), without physics."""
        assert self._box_qpos is not None, "no box in this world"
        self.data.qpos[self._box_qpos : self._box_qpos + 7] = np.r_[centre, np.roll(quaternion_xyzw, 1)]

    def box_pose(self) -> tuple[np.ndarray, float]:
        """The box's centre and yaw (PyBullet's roll-pitch-yaw yaw)."""
        centre, (w, x, y, z) = self._box_qpos_now()
        return centre, float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))

    def box_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Box centre, its z axis in the world (upright: ~ (0, 0, 1)) and its quaternion in PyBullet's (x, y, z, w)."""
        centre, quat = self._box_qpos_now()
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, quat)
        return centre, rotation.reshape(3, 3)[:, 2].copy(), np.roll(quat, -1)

    def clearances(self, bodies: set[int]) -> dict[str, float]:
        """Per obstacle, the smallest signed distance (negative: penetration) between any geom of `bodies` and it,
        up to FAR, at the present positions (kinematics are brought up to date first)."""
        model, data = self.model, self.data
        mujoco.mj_kinematics(model, data)
        mine = self._geoms_of(frozenset(bodies))
        return {
            name: min(
                (min(mujoco.mj_geomDistance(model, data, g, o, FAR, None), FAR) for g in mine for o in geoms),
                default=FAR,
            )
            for name, geoms in self.obstacle_geoms.items()
        }

    def _geoms_of(self, bodies: frozenset[int]) -> list[int]:
        """`_geoms_of` for a set of bodies, found once per set."""
        if bodies not in self._geoms:
            self._geoms[bodies] = _geoms_of(self.model, set(bodies))
        return self._geoms[bodies]

    def pad_contacts(
        self, tool_bodies_per_hand: Sequence[set[int]], robot_bodies: set[int], friction: float
    ) -> PadContacts:
        """The box's contacts with each hand's pads (tool bodies) and with the robot's other bodies, as
        sim/contacts.PadContacts (other_links: MuJoCo body ids); `friction`: the pad-box coefficient."""
        return mujoco_pad_contacts(self, tool_bodies_per_hand, robot_bodies, friction)


def _geoms_of(model: mujoco.MjModel, bodies: set[int]) -> list[int]:
    """The geoms of `bodies` that collide (contype or conaffinity set), in model order."""
    collides = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return [int(g) for g in np.flatnonzero(np.isin(model.geom_bodyid, list(bodies)) & collides)]
