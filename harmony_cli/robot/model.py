"""URDF -> OpTaS RobotModel plus the joint bookkeeping every other module needs."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np
import optas

from harmony_cli.cache import CACHE_DIR
from harmony_cli.robot.prepare import prepare_urdf
from harmony_cli.robot.urdf import wrist_sensor_joints

if TYPE_CHECKING:
    from harmony_cli.scenario.robot import RobotSpec


@dataclass(frozen=True)
class Robot:
    """A dual-arm mobile manipulator: kinematics (OpTaS), limits and the joint roles of the scenario."""

    urdf: Path
    model: optas.RobotModel
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


def load_robot(spec: RobotSpec, scenario_dir: Path) -> Robot:
    """Build the robot of a validated scenario `robot` section (paths relative to the scenario file); a URDF
    without the planar base joints gets them, and package:// meshes resolve through `package_paths`."""
    urdf = prepare_urdf(
        (scenario_dir / spec.urdf).resolve(),
        tuple(spec.base_joints),
        [(scenario_dir / p).resolve() for p in spec.package_paths],
        CACHE_DIR / "urdf",
    )
    model = optas.RobotModel(urdf_filename=str(urdf), time_derivs=[0])
    names = tuple(model.actuated_joint_names)
    home = np.zeros(len(names))
    for joint, degrees in spec.home_deg.items():
        home[names.index(joint)] = np.deg2rad(degrees)
    return Robot(
        urdf=urdf,
        model=model,
        joint_names=names,
        lower=np.array(model.lower_actuated_joint_limits).ravel(),
        upper=np.array(model.upper_actuated_joint_limits).ravel(),
        velocity_limit=np.array(model.velocity_actuated_joint_limits).ravel(),
        end_effectors=tuple(spec.end_effectors.values()),
        hand_names=tuple(spec.end_effectors.keys()),
        wrist_sensors=tuple(wrist_sensor_joints(spec, urdf).values()),
        home=home,
        base_joints=tuple(names.index(j) for j in spec.base_joints),
        pinned_joints=tuple(names.index(j) for j in spec.pinned_joints),
    )
