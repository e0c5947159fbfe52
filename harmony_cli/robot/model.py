"""URDF -> OpTaS RobotModel plus the joint bookkeeping every other module needs."""

from __future__ import annotations

import importlib
import importlib.util
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from harmony_cli.cache import CACHE_DIR
from harmony_cli.capture import captured_output
from harmony_cli.names import closest
from harmony_cli.robot.arm_points import ArmChain, arm_chains
from harmony_cli.robot.gravity import gravity_torques
from harmony_cli.robot.mimic import Coupling, coupled
from harmony_cli.robot.prepare import Mount, UrdfPlan, prepare_urdf
from harmony_cli.robot.tools import tool_link
from harmony_cli.robot.urdf import joint_types, wrist_sensor_joints
from harmony_cli.robot.urdf_form import refused_by

if TYPE_CHECKING:
    from optas.models import RobotModel

    from harmony_cli.scenario.robot import RobotSpec


def optas_robot_model() -> type[RobotModel]:
    """OpTaS's RobotModel (URDF -> CasADi kinematics) without running OpTaS's package __init__, which also imports
    its visualiser (VTK, ~1.4 s), its solvers (OSQP, CVXOPT, SciPy's optimisers) and its builder: harmony uses
    none of them. A later `import optas` anywhere still gets the whole package (the bare one is not kept)."""
    models = sys.modules.get("optas.models")
    if models is None and "optas" in sys.modules:
        models = importlib.import_module("optas.models")
    if models is None:
        spec = importlib.util.find_spec("optas")
        if spec is None:
            raise ImportError("harmony needs OpTaS (pip install pyoptas)")
        sys.modules["optas"] = importlib.util.module_from_spec(spec)  # the package without its __init__
        try:
            models = importlib.import_module("optas.models")
        finally:
            del sys.modules["optas"]
    return models.RobotModel


@dataclass(frozen=True)
class Robot:
    """A dual-arm mobile manipulator: kinematics (OpTaS), limits and the joint roles of the scenario."""

    urdf: Path
    model: RobotModel
    joint_names: tuple[str, ...]
    lower: np.ndarray  # [rad | m], per joint in `joint_names` order
    upper: np.ndarray
    velocity_limit: np.ndarray  # [rad/s | m/s]
    end_effectors: tuple[str, ...]  # link names, e.g. ("LARM_grasp", "RARM_grasp")
    hand_names: tuple[str, ...]  # labels in logs, e.g. ("left", "right")
    wrist_sensors: tuple[str, ...]  # per hand, the fixed joint whose child carries the tool (force/torque sensor)
    home: np.ndarray
    base_joints: tuple[int, ...]  # indices of the velocity-commanded virtual planar joints
    pinned_joints: tuple[int, ...]  # indices held at home in every MPC (the head)
    continuous: tuple[int, ...] = ()  # indices of joints the URDF declares continuous (unbounded)
    prismatic: tuple[int, ...] = ()  # indices of prismatic joints (base x, y included): values in metres
    notes: tuple[str, ...] = ()  # what preparing the URDF changed and what its parser said, for run.log
    home_gravity: np.ndarray | None = None  # per joint, the torque [N m | N] holding home against gravity (Pinocchio)
    effort: np.ndarray | None = None  # per joint, the URDF's effort limit
    actuators: str = "urdf"  # simulated motors: the URDF's efforts (urdf) or strong ones (ideal)
    arms: tuple[ArmChain, ...] = ()  # per hand, points along its arm kept off table tops and obstacles (none: not)
    mount: Mount | None = None  # the root link's pose on the virtual base (`mount: auto` resolved); None: at it
    couplings: tuple[Coupling, ...] = ()  # mimic joints moving with their leader (robot/mimic.py)

    def coupled(self, q):
        """`q` (numpy or CasADi) with every mimic joint at its leader's value times the multiplier plus the offset."""
        return coupled(q, self.couplings)

    @property
    def overloaded(self) -> tuple[str, ...]:
        """'joint (|tau| > effort)' for every arm joint whose URDF effort cannot hold home against gravity."""
        if self.home_gravity is None or self.effort is None:
            return ()
        return tuple(
            f"{self.joint_names[i]} ({abs(self.home_gravity[i]):.3g} > {self.effort[i]:.3g})"
            for i in range(self.n_dof)
            if i not in self.base_joints and abs(self.home_gravity[i]) > self.effort[i]
        )

    @property
    def n_dof(self) -> int:
        return len(self.joint_names)

    def index(self, joint: str) -> int:
        return self.joint_names.index(joint)

    def hand_pose(self, hand: int, q) -> tuple:
        """World position (3,) and rotation (3, 3) of an end-effector frame; numeric or CasADi `q`.

        Uses OpTaS global transforms (its `get_link_transform(link, q, base)` composes wrongly in 1.0.7).
        """
        link = self.end_effectors[hand]
        return self.model.get_global_link_position(link, q), self.model.get_global_link_rotation(link, q)

    def hand_poses_numeric(self, q: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        poses = [self.hand_pose(h, q) for h in range(len(self.end_effectors))]
        return [(np.array(cs.DM(p)), np.array(cs.DM(r))) for p, r in poses]


def urdf_plan(spec: RobotSpec, scenario_dir: Path, keep: tuple[str, ...] = ()) -> UrdfPlan:
    """What a robot section asks of its URDF (paths relative to the scenario file); `keep`: links that must stay."""
    mount = spec.mount
    return UrdfPlan(
        base_joints=tuple(spec.base_joints),
        package_paths=tuple((scenario_dir / p).resolve() for p in spec.package_paths),
        active=None if spec.active_joints is None else tuple(spec.active_joints),
        roles=(*spec.chest_joints, *spec.pinned_joints, *(j for pair in spec.mirrored_joints for j in pair)),
        home=dict(spec.home),
        tools=dict(spec.tools),
        mount=mount if mount is None or isinstance(mount, str) else (list(mount.xyz), list(mount.rpy_deg)),
        keep=tuple(spec.end_effectors.values()) + keep,
        hands=dict(spec.end_effectors),
    )


def load_robot(spec: RobotSpec, scenario_dir: Path, keep: tuple[str, ...] = ()) -> Robot:
    """Build the robot of a validated scenario `robot` section from its prepared URDF (robot/prepare.py); the
    URDF parser's complaints go to `Robot.notes`, not the console. ValueError for what cannot be built, a parser's
    refusal of the URDF included."""
    prepared = prepare_urdf(
        (scenario_dir / spec.urdf).resolve(), urdf_plan(spec, scenario_dir, keep), CACHE_DIR / "urdf"
    )
    with refused_by("OpTaS (urdf_parser_py)", spec.urdf), captured_output() as parser_output:
        model = optas_robot_model()(urdf_filename=str(prepared.path), time_derivs=[0])
    names = tuple(model.actuated_joint_names)
    home = np.zeros(len(names))
    for joint, value in prepared.home.items():
        if joint in names:
            home[names.index(joint)] = value
    x, y, yaw_deg = spec.base_pose
    for joint, value in zip(spec.base_joints, (x, y, np.deg2rad(yaw_deg)), strict=True):
        home[names.index(joint)] = value
    roles = {
        "pinned_joints": spec.pinned_joints,
        "chest_joints": spec.chest_joints,
        "mirrored_joints": [j for pair in spec.mirrored_joints for j in pair],
    }
    for field, joints in roles.items():
        for joint in joints:
            if joint not in names:
                raise ValueError(f"robot.{field}: {joint!r} is not an active joint; {closest(joint, names)}")
    with refused_by("Pinocchio (urdfdom)", spec.urdf):
        torque, effort = gravity_torques(prepared.path, names, home)
    end_effectors = spec.end_effectors | {hand: tool_link(hand) for hand in prepared.hand_tools}
    return Robot(
        urdf=prepared.path,
        model=model,
        joint_names=names,
        lower=np.array(model.lower_actuated_joint_limits).ravel(),
        upper=np.array(model.upper_actuated_joint_limits).ravel(),
        velocity_limit=np.array(model.velocity_actuated_joint_limits).ravel(),
        end_effectors=tuple(end_effectors.values()),
        hand_names=tuple(end_effectors.keys()),
        wrist_sensors=tuple(wrist_sensor_joints(spec.wrist_sensors, end_effectors, prepared.path).values()),
        home=home,
        base_joints=tuple(names.index(j) for j in spec.base_joints),
        pinned_joints=tuple(names.index(j) for j in spec.pinned_joints),
        continuous=tuple(names.index(j) for j in prepared.continuous),
        prismatic=tuple(i for i, kind in enumerate(map(joint_types(prepared.path).get, names)) if kind == "prismatic"),
        notes=tuple(prepared.notes() + [f"urdf parser: {line}" for line in parser_output]),
        home_gravity=torque,
        effort=effort,
        actuators=spec.actuators,
        arms=()
        if spec.arm_radius is None
        else arm_chains(prepared.path, tuple(end_effectors.values()), spec.arm_radius),
        mount=prepared.mount,
        couplings=tuple(
            Coupling(names.index(j), names.index(m.master), m.multiplier, m.offset) for j, m in prepared.coupled.items()
        ),
    )
