"""Points along each arm, the centres of spheres the whole-body MPC keeps clear of table tops and obstacles.

An arm is the chain of links from where the two hands' chains part (EVA: the chest; PR2, TIAGo: the torso lift) down
to the wrist (the child of the last moving joint above the hand); the fixed links below it (sensor, tool, pad) are
the hand's, which works on the box, just above a table. A link's points lie on the axis of each primitive
collision shape (a cylinder's axis, a box's longest centre line, a sphere's centre: EVA's LARM2 hangs below its
elbow, off the chain) and, for a link with a mesh (whose extent is not read), on its skeleton, the segment from
its origin to the next link's; a link without collision shapes has none.

Spheres of radius r whose centres keep r + m from a body, every s along a segment, keep the capsule of radius r
round it off the body when s <= 2 sqrt(2 r m + m^2): the segment's point nearest the body is within s / 2 of a
centre, at sqrt((r + m)^2 - s^2 / 4) >= r from it. Segments are sampled at that spacing (a point within half of
it of one already on its link is dropped), so the spheres stand for capsules of the robot's arm radius."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import casadi as cs
import numpy as np

from harmony_cli.robot.urdf import required

MARGIN = 0.01  # [m] the spheres' clearance from tables and obstacles: no touch, yet the forearms may pass near


def spacing(radius: float) -> float:
    """[m] the largest spacing of spheres of `radius` kept MARGIN off a body that keeps their capsule off it."""
    return 2 * math.sqrt(2 * radius * MARGIN + MARGIN**2)


@dataclass(frozen=True)
class ChainJoint:
    """A joint of an arm's chain: its type, origin (4 x 4, in its parent link's frame), axis and the points (n, 3)
    on its child link, in the child's frame."""

    name: str
    kind: str
    origin: np.ndarray
    axis: np.ndarray
    points: np.ndarray


@dataclass(frozen=True)
class ArmChain:
    """One arm: the link where the hands' chains part (`base_link`) and the joints from it down to the wrist;
    `levers`: per moving joint from the root down to the wrist, a bound on how fast any of the arm's points moves
    per unit of that joint's motion, in every configuration (lever_bounds)."""

    base_link: str
    joints: tuple[ChainJoint, ...]
    levers: tuple[tuple[str, float], ...] = ()

    @property
    def n_points(self) -> int:
        return sum(len(j.points) for j in self.joints)

    def positions(self, base, joint_value: Callable[[str], object]) -> list:
        """The points in the world, numeric or CasADi: `base` is base_link's world transform (4 x 4) and
        joint_value(name) a moving joint's value."""
        T, out = base, []
        for joint in self.joints:
            T = T @ joint.origin
            if joint.kind != "fixed":
                T = T @ _motion(joint.kind, joint.axis, joint_value(joint.name))
            out += [T[:3, :3] @ p + T[:3, 3] for p in joint.points]
        return out


def arm_chains(urdf: Path, end_effectors: tuple[str, ...], radius: float) -> tuple[ArmChain, ...]:
    """Each hand's arm (see the module) with its points for spheres of `radius` [m]; an arm with no moving joint
    of its own has no points."""
    step = spacing(radius)
    root = ET.parse(urdf).getroot()
    parent_joint = {required(j.find("child"), "link", "joint child"): j for j in root.findall("joint")}
    links = {required(link, "name", "link"): link for link in root.findall("link")}
    paths = [_path(parent_joint, ee) for ee in end_effectors]
    shared = 0
    while all(len(p) > shared + 1 and p[shared] == paths[0][shared] for p in paths):
        shared += 1
    chains = []
    for path in paths:
        arm = path[shared:]  # the links below the last shared one
        moving = [i for i, link in enumerate(arm) if parent_joint[link].get("type") != "fixed"]
        joints: list[ChainJoint] = []
        if moving:
            arm = arm[: moving[-1] + 1]  # down to the wrist
            for i, link in enumerate(arm):
                next_origin = None
                if i + 1 < len(arm) and parent_joint[arm[i + 1]].get("type") != "prismatic":
                    next_origin = _origin(parent_joint[arm[i + 1]])[:3, 3]
                points = _link_points(links[link], next_origin, step) if i >= moving[0] else np.zeros((0, 3))
                joints.append(_chain_joint(parent_joint[link], points))
        above = [parent_joint[link] for link in path[1:shared]]  # root to the link where the chains part
        chains.append(ArmChain(path[shared - 1], tuple(joints), lever_bounds(above, joints)))
    return tuple(chains)


def lever_bounds(above: list[ET.Element], joints: list[ChainJoint]) -> tuple[tuple[str, float], ...]:
    """Per moving joint of the path from the root through `above` down the arm's `joints`, a bound on |dp/dq| for
    every arm point p in every configuration: 1 for a prismatic joint (p moves along its unit axis); for a
    revolute one the point's distance from the joint's origin, at most the sum of the origins' offsets from it
    down to the point's link, every prismatic joint's travel between, and the point's offset on its link."""
    path = [(required(j, "name", "joint"), str(j.get("type")), _origin(j)[:3, 3], _travel(j)) for j in above]
    path += [(j.name, j.kind, j.origin[:3, 3], 0.0) for j in joints]
    reach = [float(np.linalg.norm(j.points, axis=1).max(initial=-np.inf)) for j in joints]
    reach = [-np.inf] * len(above) + reach  # the farthest point on each link of the path (none: -inf)
    bounds = []
    for i, (name, kind, _, _) in enumerate(path):
        if kind == "fixed":
            continue
        farthest, along = -np.inf, 0.0
        for offset, (_, later_kind, origin, travel) in zip(reach[i + 1 :], path[i + 1 :]):
            along += float(np.linalg.norm(origin)) + (travel if later_kind == "prismatic" else 0.0)
            farthest = max(farthest, along + offset)
        farthest = max(farthest, reach[i])  # points on the joint's own child link
        if np.isfinite(farthest):
            bounds.append((name, 1.0 if kind == "prismatic" else farthest))
    return tuple(bounds)


def _travel(joint: ET.Element) -> float:
    """[m] how far a prismatic joint slides from its zero at most (inf without limits)."""
    limit = joint.find("limit")
    if joint.get("type") != "prismatic":
        return 0.0
    if limit is None or limit.get("lower") is None or limit.get("upper") is None:
        return np.inf
    return max(abs(float(limit.get("lower", 0))), abs(float(limit.get("upper", 0))))


def _path(parent_joint: dict[str, ET.Element], link: str) -> list[str]:
    """The links from the root down to `link`."""
    path = [link]
    while path[0] in parent_joint:
        path.insert(0, required(parent_joint[path[0]].find("parent"), "link", "joint parent"))
    return path


def _chain_joint(joint: ET.Element, points: np.ndarray) -> ChainJoint:
    axis = joint.find("axis")
    xyz = np.array([float(v) for v in ("1 0 0" if axis is None else axis.get("xyz", "1 0 0")).split()])
    if not xyz.any():  # a fixed joint's axis, which packages often write as zero: it turns nothing
        xyz = np.array([1.0, 0.0, 0.0])
    return ChainJoint(
        required(joint, "name", "joint"), str(joint.get("type")), _origin(joint), xyz / np.linalg.norm(xyz), points
    )


def _link_points(link: ET.Element, next_origin: np.ndarray | None, spacing: float) -> np.ndarray:
    """Points on a link (its frame): its primitive collision shapes' axes and, if it has a mesh, its skeleton to
    the next link's origin (that end is the next link's own point), sampled at most `spacing` apart, near
    duplicates dropped. A link without collision shapes has none: nothing of it can touch."""
    shapes = [_shape_axis(c) for c in link.findall("collision")]
    segments = [(*axis, False) for axis in shapes if axis is not None]
    if any(axis is None for axis in shapes):
        segments.insert(0, (np.zeros(3), np.zeros(3) if next_origin is None else next_origin, next_origin is not None))
    kept: list[np.ndarray] = []
    for a, b, open_end in segments:
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / spacing))
        for k in range(n if open_end else n + 1):
            point = a + (b - a) * k / n
            if all(np.linalg.norm(point - other) >= spacing / 2 for other in kept):
                kept.append(point)
    return np.array(kept).reshape(-1, 3)


def _shape_axis(collision: ET.Element) -> tuple[np.ndarray, np.ndarray] | None:
    """The ends of a primitive collision shape's axis in its link's frame (a sphere: its centre twice); None for
    a mesh."""
    geometry = collision.find("geometry")
    shape = None if geometry is None or len(geometry) == 0 else geometry[0]
    if shape is None:
        return None
    if shape.tag == "cylinder":
        half = np.array([0.0, 0.0, float(shape.get("length", 0)) / 2])
    elif shape.tag == "box":
        size = np.array([float(v) for v in shape.get("size", "0 0 0").split()])
        half = np.where(np.arange(3) == np.argmax(size), size / 2, 0.0)
    elif shape.tag == "sphere":
        half = np.zeros(3)
    else:
        return None
    T = _origin(collision)
    return T[:3, :3] @ -half + T[:3, 3], T[:3, :3] @ half + T[:3, 3]


def _origin(element: ET.Element) -> np.ndarray:
    """An element's <origin> as a 4 x 4 transform (URDF rpy: fixed axes x, y, z)."""
    origin = element.find("origin")
    T = np.eye(4)
    if origin is not None:
        roll, pitch, yaw = (float(v) for v in origin.get("rpy", "0 0 0").split())
        T[:3, :3] = _rz(yaw) @ _ry(pitch) @ _rx(roll)
        T[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    return T


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _motion(kind: str, axis: np.ndarray, value):
    """The transform a moving joint adds at `value` (numeric or CasADi): a turn about `axis` or a slide along it."""
    symbolic = isinstance(value, (cs.SX, cs.MX))
    T = cs.SX.eye(4) if symbolic else np.eye(4)
    if kind == "prismatic":
        for i in range(3):
            T[i, 3] = axis[i] * value
        return T
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = (cs.sin(value), cs.cos(value)) if symbolic else (math.sin(value), math.cos(value))
    R = np.eye(3) + s * K + (1 - c) * (K @ K)  # Rodrigues
    for i in range(3):
        for j in range(3):
            T[i, j] = R[i, j]
    return T
