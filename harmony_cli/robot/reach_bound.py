"""How far a hand can possibly be from the base, as a bound that holds for every joint value: the arm's links laid
end to end from its first moving joint. A target beyond it is out of reach for certain, which is what a scene may
be refused on before the robot moves (a local optimum of the reach, robot/reach.py, is a value the arm does reach,
not a bound).

The hand is at o + R (t_1 + R_1 (t_2 + ...)), o the first moving joint's origin (fixed in the base frame: only
fixed joints lie between it and the base's yaw joint) and t_k the joint origins' offsets after it, so its distance
from o is at most the sum of |t_k| plus every prismatic joint's travel on the way. At height z the hand is then
within r + sqrt(L^2 - (z - h)^2) of the base's origin in plan view, with r and h o's plan-view distance from the
base's origin and its height."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from harmony_cli.robot.model import Robot
from harmony_cli.robot.reach import home_at_origin
from harmony_cli.robot.urdf import required


@dataclass(frozen=True)
class ReachBound:
    """A hand's first moving joint at plan-view distance `offset` [m] from the base's origin and at `height` [m],
    and the longest the rest of the arm can stretch from it, `length` [m]."""

    offset: float
    height: float
    length: float

    def radius(self, z: float) -> float | None:
        """[m] the farthest the hand can be from the base's origin in plan view at height `z`; None when the
        height is out of reach."""
        rise = z - self.height
        if abs(rise) > self.length:
            return None
        return self.offset + float(np.sqrt(self.length**2 - rise**2))


def reach_bound(robot: Robot, hand: int) -> ReachBound:
    """The bound for hand number `hand` from the robot's prepared URDF."""
    chain = _chain(robot, robot.end_effectors[hand])
    moving = next(i for i, joint in enumerate(chain) if joint.get("type") != "fixed")
    first, rest = chain[moving], chain[moving + 1 :]
    q = home_at_origin(robot)
    name = required(first, "name", "joint")
    if first.get("type") == "prismatic" and name in robot.joint_names:
        q[robot.index(name)] = 0.0  # its child's frame at the joint's origin
    child = required(first.find("child"), "link", "joint child")
    origin = np.asarray(robot.model.get_global_link_position(child, q), dtype=float).ravel()
    length = sum(_offset(joint) for joint in rest)
    length += sum(_travel(joint) for joint in chain[moving:] if joint.get("type") == "prismatic")
    return ReachBound(float(np.hypot(origin[0], origin[1])), float(origin[2]), float(length))


def _chain(robot: Robot, link: str) -> list[ET.Element]:
    """The joints from the base's yaw joint (excluded) down to `link`, top first."""
    root = ET.parse(robot.urdf).getroot()
    parent_joint = {required(j.find("child"), "link", "joint child"): j for j in root.findall("joint")}
    yaw = robot.joint_names[robot.base_joints[2]]
    chain: list[ET.Element] = []
    while link in parent_joint and required(parent_joint[link], "name", "joint") != yaw:
        chain.insert(0, parent_joint[link])
        link = required(parent_joint[link].find("parent"), "link", "joint parent")
    return chain


def _offset(joint: ET.Element) -> float:
    origin = joint.find("origin")
    xyz = "0 0 0" if origin is None else origin.get("xyz", "0 0 0")
    return float(np.linalg.norm([float(v) for v in xyz.split()]))


def _travel(joint: ET.Element) -> float:
    """[m] the farthest a prismatic joint moves from 0 (its limits)."""
    limit = joint.find("limit")
    if limit is None:
        return 0.0
    return max(abs(float(limit.get("lower", 0.0))), abs(float(limit.get("upper", 0.0))))
