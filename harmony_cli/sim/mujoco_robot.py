"""The robot in MuJoCo: its model from the prepared URDF (robot_spec), commanded and read like PyBullet's
(MujocoRobot).

The model. MuJoCo's own URDF compiler reads `robot.urdf` (the prepared copy: virtual planar base joints above the
root, locked joints already fixed, mesh paths absolute), told by an injected <mujoco><compiler/> element to keep
fixed links as bodies (the grasp frames and the wrist sensors' child links must exist), to balance inertias that
violate the triangle inequality (MuJoCo refuses them, PyBullet does not) and to discard visuals; .dae meshes, which
MuJoCo cannot read, are converted once and cached (sim/mujoco_meshes.py). The robot's
geoms collide with the world but not with each other, as in PyBullet, which loads the robot without
URDF_USE_SELF_COLLISION. Mimic followers are tied to their leaders by joint equalities (value = multiplier *
leader + offset).

The motors. Base joints: a velocity servo, force = kv (qd_t - qd). Every other joint: a position + velocity servo,
force = kp (q_t - q) + kv (qd_t - qd), one affine actuator (ctrl = kp q_t + kv qd_t). Both are clamped at the URDF
effort (IDEAL_EFFORT for actuators: ideal). Gravity is compensated through the actuators (body gravcomp 1, joint
actgravcomp): MuJoCo adds each joint's gravity torque to its actuator force and clamps the sum at the joint's
actuator force range (the effort), so a servo holds home without a steady error and a joint whose effort cannot
carry its arm sags, as a real motor would. The compensation acts through the joints only, so the wrist sensors
still carry the tool's weight (a real sensor does).

The gains: one rule for every robot and scene. Stiffness from the motor: kp = the URDF's effort / FULL_EFFORT_ERROR
(`actuators: ideal` lifts the clamp, not the stiffness), so a
motor gives its full effort a small angle off its target whatever the inertia behind it (PyBullet's motors are
velocity constraints, stiff up to their effort; a gain scaled by the link's inertia left a light wrist so soft that
the millimetres of the force loop's squeeze were lost in its give). Each servo is critically damped and its natural
frequency is BANDWIDTH_STEPS / physics_dt: where the link's own inertia is too light for that, the motor's reflected
rotor inertia (joint armature, which real geared motors have and URDFs leave out) makes up the difference. Why: an
explicit spring stiffer than the step allows, or a clamped servo on a light link (its full effort changing the
joint's velocity by tens of rad/s in one step), rings or diverges. The base: a velocity servo of the same
bandwidth for its inertia at home. The damping terms are integrated implicitly (implicitfast).

The wrist sensors: a MuJoCo force and torque sensor at a site on each sensor joint's child body reads the support
the wrist gives the tool (the bodies below the sensor), compensated for the tool's gravity and inertia
(sim/mujoco_wrench.py): the external wrench the environment applies to the tool, what sim/wrench.py reads in
PyBullet. Why the sensor and not the contact forces on the tool: it also sees welds,
equalities and applied forces, as a real sensor does.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.robot.urdf import required
from harmony_cli.sim.motors import efforts
from harmony_cli.sim.mujoco_meshes import mujoco_urdf
from harmony_cli.sim.mujoco_wrench import ToolWrenches

if TYPE_CHECKING:
    from harmony_cli.robot.model import Robot
    from harmony_cli.scenario.models import SimSpec

FULL_EFFORT_ERROR = 0.002  # [rad | m] the position error at which a joint's motor gives its full effort
BANDWIDTH_STEPS = 0.3  # every servo's natural frequency times the physics step (module docstring)
GRAVITY = (0.0, 0.0, -9.81)
HAND_SITE = "harmony_hand_{}"  # a site at each hand frame (end-effector link origin)
WRIST_SITE = "harmony_wrist_{}"  # a site at each wrist sensor joint's child body origin
COMPILER = (
    '<mujoco><compiler fusestatic="false" balanceinertia="true" discardvisual="true" strippath="false"/></mujoco>'
)
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 2, 1  # robot geoms touch the world's (1, 1) but not each other


def robot_spec(robot: Robot, sim_spec: SimSpec) -> mujoco.MjSpec:
    """The robot as a MuJoCo spec: joints, hand and wrist sites, wrist sensors, servos with their gains, mimic
    equalities; timestep sim_spec.physics_dt, implicitfast. Add a world to it, compile, bind a MujocoRobot."""
    urdf = ET.parse(robot.urdf).getroot()
    spec = mujoco.MjSpec.from_string(mujoco_urdf(robot.urdf, COMPILER))
    spec.option.timestep = sim_spec.physics_dt
    spec.option.gravity = GRAVITY
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    for body in spec.bodies:
        if body.name != "world":
            body.gravcomp = 1.0
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
    for h, link in enumerate(robot.end_effectors):
        spec.body(link).add_site(name=HAND_SITE.format(h))
    for h, link in enumerate(_sensor_children(urdf, robot.wrist_sensors)):
        spec.body(link).add_site(name=WRIST_SITE.format(h))
        spec.add_sensor(
            type=mujoco.mjtSensor.mjSENS_FORCE,
            objtype=mujoco.mjtObj.mjOBJ_SITE,
            objname=WRIST_SITE.format(h),
            name=f"{WRIST_SITE.format(h)}_force",
        )
        spec.add_sensor(
            type=mujoco.mjtSensor.mjSENS_TORQUE,
            objtype=mujoco.mjtObj.mjOBJ_SITE,
            objname=WRIST_SITE.format(h),
            name=f"{WRIST_SITE.format(h)}_torque",
        )
    for coupling in robot.couplings:
        spec.add_equality(
            type=mujoco.mjtEq.mjEQ_JOINT,
            name1=robot.joint_names[coupling.follower],
            name2=robot.joint_names[coupling.leader],
            data=np.r_[coupling.offset, coupling.multiplier, np.zeros(mujoco.mjNEQDATA - 2)],
        )
    _add_servos(spec, robot, sim_spec, _home_inertias(spec, robot))
    return spec


def tool_bodies(spec: mujoco.MjSpec, robot: Robot) -> list[mujoco.MjsBody]:
    """Every tool's bodies (those below a wrist sensor joint): the pads that touch what the hands hold."""
    urdf = ET.parse(robot.urdf).getroot()
    bodies: list[mujoco.MjsBody] = []
    for link in _sensor_children(urdf, robot.wrist_sensors):
        below = [spec.body(link)]
        while below:
            body = below.pop()
            bodies.append(body)
            below += body.bodies
    return bodies


def _sensor_children(urdf: ET.Element, sensors: tuple[str, ...]) -> list[str]:
    """The child link of each wrist sensor joint."""
    child = {
        required(j, "name", "joint"): required(j.find("child"), "link", "joint child") for j in urdf.findall("joint")
    }
    return [child[joint] for joint in sensors]


def _home_inertias(spec: mujoco.MjSpec, robot: Robot) -> np.ndarray:
    """Per joint, its diagonal of the joint-space inertia matrix at home (the spec compiled as it is)."""
    model = spec.compile()
    data = mujoco.MjData(model)
    dofs = [model.jnt_dofadr[model.joint(name).id] for name in robot.joint_names]
    data.qpos[[model.jnt_qposadr[model.joint(name).id] for name in robot.joint_names]] = robot.home
    mujoco.mj_forward(model, data)
    inertia = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, inertia)
    return inertia[dofs, dofs]


def _add_servos(spec: mujoco.MjSpec, robot: Robot, sim_spec: SimSpec, inertia: np.ndarray) -> None:
    """A velocity servo per base joint, a position + velocity servo per other joint (module docstring)."""
    effort, omega = efforts(robot), BANDWIDTH_STEPS / sim_spec.physics_dt
    urdf_effort = np.asarray(robot.effort, dtype=float)  # the servos' stiffness, also under actuators: ideal
    for i, name in enumerate(robot.joint_names):
        joint = spec.joint(name)
        joint.actfrclimited = True
        joint.actfrcrange = [-effort[i], effort[i]]
        joint.actgravcomp = True
        actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.forcelimited = True
        actuator.forcerange = [-effort[i], effort[i]]
        actuator.ctrllimited = False
        actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        if i in robot.base_joints:
            kv = inertia[i] * omega
            actuator.gainprm[0], actuator.biasprm[:3] = kv, [0.0, 0.0, -kv]
        else:
            kp = urdf_effort[i] / FULL_EFFORT_ERROR
            joint.armature = max(0.0, kp / omega**2 - inertia[i])  # the rotor inertia the bandwidth needs
            kv = 2 * np.sqrt(kp * (inertia[i] + joint.armature))
            actuator.gainprm[0], actuator.biasprm[:3] = 1.0, [0.0, -kp, -kv]


class MujocoRobot:
    """The robot of a compiled robot_spec (a world possibly added): ids bound by name. Readings are of `data` as
    mj_forward leaves it (`step` ends with one), joint vectors in robot.joint_names order."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, robot: Robot, sim_spec: SimSpec):
        self.model, self.data, self.robot, self.spec = model, data, robot, sim_spec
        joints = [model.joint(name).id for name in robot.joint_names]
        self.qpos = model.jnt_qposadr[joints]
        self.dofs = model.jnt_dofadr[joints]
        self.actuators = np.array([model.actuator(name).id for name in robot.joint_names])
        self.base = list(robot.base_joints)
        self.others = [i for i in range(robot.n_dof) if i not in robot.base_joints]
        self.kp = -model.actuator_biasprm[self.actuators, 1]
        self.kv = -model.actuator_biasprm[self.actuators, 2]
        hands = range(len(robot.end_effectors))
        self.hand_sites = [model.site(HAND_SITE.format(h)).id for h in hands]
        self.wrist_sites = [model.site(WRIST_SITE.format(h)).id for h in hands]
        self.sensor_rows = [
            (
                model.sensor_adr[model.sensor(f"{WRIST_SITE.format(h)}_force").id],
                model.sensor_adr[model.sensor(f"{WRIST_SITE.format(h)}_torque").id],
            )
            for h in hands
        ]
        root = model.body_rootid[model.jnt_bodyid[joints[0]]]
        self.body_ids = {b for b in range(model.nbody) if b and model.body_rootid[b] == root}
        self.tool_bodies = [self._subtree(model.site_bodyid[site]) for site in self.wrist_sites]
        self.tool_wrenches = ToolWrenches(
            model, data, self.hand_sites, self.wrist_sites, self.sensor_rows, self.tool_bodies
        )

    def _subtree(self, top: int) -> list[int]:
        """`top` and the bodies below it, parents before children."""
        below = [top]
        for b in range(top + 1, self.model.nbody):
            if self.model.body_parentid[b] in below:
                below.append(b)
        return below

    def link_name(self, body_id: int) -> str:
        return self.model.body(body_id).name

    def reset_home(self) -> None:
        """Every joint at home, at rest, the servos holding it."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.qpos] = self.robot.home
        self.apply(self.robot.home, np.zeros(self.robot.n_dof))
        mujoco.mj_forward(self.model, self.data)

    def step(self, substeps: int) -> None:
        """`substeps` physics steps under the last command, then mj_forward: every reading is of the new state."""
        for _ in range(substeps):
            mujoco.mj_step(self.model, self.data)
        mujoco.mj_forward(self.model, self.data)

    def place(self, joints: dict[str, float]) -> None:
        """Joint positions by name (those of the robot's joints; others ignored), without physics."""
        for name, value in joints.items():
            if name in self.robot.joint_names:
                self.data.qpos[self.qpos[self.robot.joint_names.index(name)]] = value

    def q(self) -> np.ndarray:
        return self.data.qpos[self.qpos].copy()

    def qd(self) -> np.ndarray:
        return self.data.qvel[self.dofs].copy()

    def apply(self, q_target: np.ndarray, qd_target: np.ndarray) -> None:
        """Base joints: velocity targets; the others: position + velocity targets."""
        ctrl = self.data.ctrl
        ctrl[self.actuators[self.base]] = qd_target[self.base]
        others = self.others
        ctrl[self.actuators[others]] = self.kp[others] * q_target[others] + self.kv[others] * qd_target[others]

    def hands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The hand frames: positions (hands, 3), rotations (hands, 3, 3), linear velocities (hands, 3) and yaw
        rates (hands,), in the world."""
        data, velocity = self.data, np.zeros(6)
        linear, yaw_rates = [], []
        for site in self.hand_sites:
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_SITE, site, velocity, 0)
            linear.append(velocity[3:].copy())
            yaw_rates.append(velocity[2])
        positions = data.site_xpos[self.hand_sites].copy()
        return (
            positions,
            data.site_xmat[self.hand_sites].reshape(-1, 3, 3).copy(),
            np.array(linear),
            np.array(yaw_rates),
        )

    def wrenches(self) -> np.ndarray:
        """(hands, 6): the external force [N] and torque about the grasp origin [N m] the environment applies to each
        hand's tool, in the grasp frame (sim/wrench.py's frame and signs; sim/mujoco_wrench.py)."""
        return self.tool_wrenches.read()
