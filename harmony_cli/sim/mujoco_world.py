"""The scene of a scenario in MuJoCo: a ground plane, tables (top and legs, as sim/world.py builds them), the box as
a free body and obstacles (static bodies, moving ones mocap bodies), added to the robot's MjSpec before it is
compiled; then read back from the compiled model by name: `table:<name>` (geoms `table:<name>:top`,
`table:<name>:leg<i>`), `obstacle:<name>` (body and geom), `box` (body and geom), `ground`.

Contact parameters, chosen once for every scene (`contact_options`, `pad_contact_params`):
- Elliptic friction cones with impratio 10: the elliptic cone is Coulomb's law itself (a pyramid lets a pad slip
  sooner in some directions than others), and a ratio of frictional to normal impedance above 1 is what MuJoCo
  advises against slip of a grasped object (a box held by friction alone would creep out of the pads otherwise).
- The pads (robot geoms below the wrist sensors, which the robot's builder makes) get geom priority 2 (the box 1,
  everything else 0): the higher priority's friction, condim, solref and solimp make a contact. So pad-box contacts
  have condim 4 (torsional friction: the box does not pivot between the pads) with the box's sliding and spinning
  friction, what PyBullet uses (the product of the box's and the robot's friction, ROBOT_FRICTION = 1); the box
  against another robot link uses the box's friction and condim 3; against a table, explicit pairs with the
  product of the box's and the table's friction, as PyBullet (PyBullet's tables have no spinning friction).
- Rigid contacts keep MuJoCo's default solref (0.02 s, damping ratio 1: at least twice a 4 ms step) and solimp.
- Compliant pads (sim.pad_stiffness K [N/m], pad_damping D [N s/m]): MuJoCo's direct solref (-k, -b) is a spring
  per unit of the contact's effective mass, scaled by the impedance d: with solimp d constant (dmin = dmax = d)
  one contact of effective mass m behaves as K = m k / (1 - d) and D = m b / (1 - d) (checked with a ball resting
  on a plane). The pads press the box: m is the box's mass, so solref = (-K (1 - d) / m, -D (1 - d) / m). Each
  contact point is such a spring, as with PyBullet's contactStiffness: a pad's face on the box's face makes 4.
  The spring is the pad's along its normal only: a geom's solref sets the friction directions too, and a pad
  as soft in shear lets a lifted box slide centimetres down the pads and pivot between them (PyBullet's
  contactStiffness leaves friction rigid). So a compliant pad's contacts with the box are explicit pairs with
  the pad's solref along the normal and MuJoCo's default in the friction directions (solreffriction)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.maths.shapes import table_legs
from harmony_cli.sim.mujoco_contacts import mujoco_pad_contacts
from harmony_cli.tasks.motion import centre_at

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import BoxSpec, ObstacleSpec, TableSpec, WorldSpec
    from harmony_cli.sim.contacts import PadContacts

FAR = 5.0  # [m] clearances beyond this are reported as FAR (as sim/world.py)
IMPRATIO = 10.0  # frictional over normal impedance: a held box does not creep out of the pads
PAD_IMPEDANCE = 0.9  # constant impedance d of compliant pads (solimp dmin = dmax)
RIGID_FRICTION = [0.02, 1.0]  # MuJoCo's default solref: the pads' friction on the box is not the pads' spring
PAD_PRIORITY, BOX_PRIORITY = 2, 1
TORSIONAL_CONDIM = 4  # normal, two tangents and spinning about the normal
ROLLING = 1e-4  # rolling friction (unused with condim <= 4; MuJoCo's default)
BOX_MASS = 0.8  # [kg] BoxSpec's default: the pads' effective mass without a box
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


def contact_options(spec: mujoco.MjSpec, sim_spec: SimSpec) -> None:
    """The step and the friction model every scene shares (see the module's docstring)."""
    spec.option.timestep = sim_spec.physics_dt
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO


def pad_contact_params(sim_spec: SimSpec, box: BoxSpec | None = None) -> dict:
    """MjsGeom attributes of a pad: priority, condim, friction (the box's sliding and spinning friction), and with
    sim.pad_stiffness set, solref and solimp making the pad a spring of that stiffness and damping against the box."""
    sliding, spinning = (1.0, 0.1) if box is None else (box.friction, box.spinning_friction)
    params: dict = {
        "priority": PAD_PRIORITY,
        "condim": TORSIONAL_CONDIM,
        "friction": [sliding, spinning, ROLLING],
    }
    if sim_spec.pad_stiffness is not None:
        scale = (1.0 - PAD_IMPEDANCE) / (BOX_MASS if box is None else box.mass)
        params["solref"] = [-sim_spec.pad_stiffness * scale, -sim_spec.pad_damping * scale]
        params["solimp"] = [PAD_IMPEDANCE, PAD_IMPEDANCE, 0.001, 0.5, 2.0]
    return params


def set_pad_contacts(
    spec: mujoco.MjSpec, pads: Iterable[mujoco.MjsBody], sim_spec: SimSpec, box: BoxSpec | None = None
) -> None:
    """Give the geoms of the pads' bodies (of the robot's MjSpec, after add_world, before compiling)
    `pad_contact_params`; with compliant pads and a box, their contacts with the box as explicit pairs whose
    friction is rigid (RIGID_FRICTION), the automatic ones excluded (module docstring)."""
    params = pad_contact_params(sim_spec, box)
    paired = box is not None and sim_spec.pad_stiffness is not None
    sliding, spinning = params["friction"][:2]
    for body in pads:
        for i, geom in enumerate(body.geoms):
            for key, value in params.items():
                setattr(geom, key, value)
            if paired:
                geom.name = geom.name or f"{body.name}:pad{i}"
                pair = spec.add_pair(geomname1=geom.name, geomname2="box", condim=TORSIONAL_CONDIM)
                pair.friction = [sliding, sliding, spinning, ROLLING, ROLLING]
                pair.solref, pair.solimp, pair.solreffriction = params["solref"], params["solimp"], RIGID_FRICTION
        if paired:
            spec.add_exclude(bodyname1=body.name, bodyname2="box")


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
            _box_on_table(spec, world.box, table)


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


def _box_on_table(spec: mujoco.MjSpec, b: BoxSpec, t: TableSpec) -> None:
    """The box's contacts with a table's top and legs as explicit pairs with the product of the two frictions, as
    PyBullet combines them (MuJoCo would take the box's alone); the automatic contacts between them excluded."""
    spec.add_exclude(bodyname1="box", bodyname2=f"table:{t.name}")
    sliding = b.friction * t.friction
    for part in ["top", *(f"leg{i}" for i in range(len(table_legs(t))))]:
        spec.add_pair(
            geomname1="box",
            geomname2=f"table:{t.name}:{part}",
            condim=3,
            friction=[sliding, sliding, 0.0, ROLLING, ROLLING],
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
        mujoco.mj_kinematics(self.model, self.data)
        mine = _geoms_of(self.model, bodies)
        return {
            name: min(
                (min(mujoco.mj_geomDistance(self.model, self.data, g, o, FAR, None), FAR) for g in mine for o in geoms),
                default=FAR,
            )
            for name, geoms in self.obstacle_geoms.items()
        }

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
