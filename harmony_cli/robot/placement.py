"""Placing the robot in the world: the virtual planar base (x, y, yaw joints above the robot's root link) that
OpTaS needs for a mobile base (it handles no planar or floating joints), and the root's mounting pose on it."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from harmony_cli.robot.origin import pose_matrix, set_origin
from harmony_cli.robot.urdf import required

BASE_LIMIT = 1000.0
BASE_EFFORT = 1e4
BASE_VELOCITIES = (1.5, 1.5, 2.0)  # x, y [m/s], yaw [rad/s]
BASE_AXES = ("1 0 0", "0 1 0", "0 0 1")
BASE_TYPES = ("prismatic", "prismatic", "revolute")
LINK_PREFIXES = ("", "harmony_")  # the first one whose new link names are all free is used


def ensure_base_joints(
    robot: ET.Element, urdf: Path, base_joints: tuple[str, ...], mount: tuple[list[float], list[float]] | None = None
) -> bool:
    """Add the x/y/yaw base joints above the root link unless they all exist; True if added. `mount` (xyz [m],
    rpy [deg]) places the root link on the yaw joint's frame (default: at it)."""
    joint_names = {joint.get("name") for joint in robot.findall("joint")}
    present = [name for name in base_joints if name in joint_names]
    if len(present) == len(base_joints):
        if mount is not None:
            raise ValueError(
                f"robot.mount: {urdf.name} has its own base joints {list(base_joints)}; a mount places only "
                "a robot on the base harmony adds: remove mount or the URDF's base joints"
            )
        return False
    if present:
        missing = [name for name in base_joints if name not in joint_names]
        raise ValueError(
            f"{urdf}: base joints {missing} are missing while {present} exist; "
            "give all three virtual base joints or none"
        )
    root_link = root_link_of(robot, urdf)
    own = planar_base(robot, root_link)
    if own:
        raise ValueError(
            f"robot.base_joints: {list(base_joints)} are not joints of {urdf.name}, which has its own planar base "
            f"{own}: name those (robot.base_joints: [{', '.join(own)}]); a second base would be added on top"
        )
    link_names = {link.get("name") for link in robot.findall("link")}
    new_links = ("world_origin", "base_px", "base_py", "base_mount")
    prefix = next((p for p in LINK_PREFIXES if not link_names & {p + name for name in new_links}), None)
    if prefix is None:
        raise ValueError(f"{urdf}: cannot add a virtual base, link names {'/'.join(new_links)} are taken")
    chain = [prefix + name for name in new_links[:3]] + [root_link if mount is None else prefix + new_links[3]]
    new_elements = [_tiny_link(name) for name in chain[:3]]
    for i, name in enumerate(base_joints):
        new_elements.append(_base_joint(name, BASE_TYPES[i], chain[i], chain[i + 1], BASE_AXES[i], BASE_VELOCITIES[i]))
    if mount is not None:  # the root hangs from a fixed joint below the yaw joint's child
        new_elements.append(_tiny_link(chain[3]))
        joint = ET.Element("joint", name=f"{prefix}mount_joint", type="fixed")
        ET.SubElement(joint, "parent", link=chain[3])
        ET.SubElement(joint, "child", link=root_link)
        set_origin(joint, pose_matrix(mount[0], np.deg2rad(mount[1])))
        new_elements.append(joint)
    robot[0:0] = new_elements  # first in file order, so first among the actuated joints
    return True


def root_link_of(robot: ET.Element, urdf: Path) -> str:
    """The one link that is no joint's child."""
    children = {required(joint.find("child"), "link", "joint child") for joint in robot.findall("joint")}
    roots = [required(link, "name", "link") for link in robot.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise ValueError(f"{urdf}: expected one root link, found {roots}")
    return roots[0]


def planar_base(robot: ET.Element, root_link: str) -> list[str]:
    """The URDF's own virtual planar base, if it has one: the first three movable joints below the root along an
    unbranched chain are prismatic, prismatic, revolute (or continuous); else []."""
    below: dict[str, list[ET.Element]] = {}
    for joint in robot.findall("joint"):
        parent = joint.find("parent")
        below.setdefault(parent.get("link", "") if parent is not None else "", []).append(joint)
    movable: list[ET.Element] = []
    link = root_link
    while len(movable) < 3 and len(below.get(link, [])) == 1:
        joint = below[link][0]
        if joint.get("type") != "fixed":
            movable.append(joint)
        child = joint.find("child")
        link = child.get("link", "") if child is not None else ""
    types = [j.get("type") for j in movable]
    if len(types) == 3 and types[:2] == ["prismatic", "prismatic"] and types[2] in ("revolute", "continuous"):
        return [str(j.get("name")) for j in movable]
    return []


def _tiny_link(name: str) -> ET.Element:
    """A geometry-free, nearly massless link (1 g: simulators replace a missing inertial by 1 kg)."""
    link = ET.Element("link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value="1e-3")
    ET.SubElement(inertial, "inertia", ixx="1e-6", ixy="0", ixz="0", iyy="1e-6", iyz="0", izz="1e-6")
    return link


def _base_joint(name: str, kind: str, parent: str, child: str, axis: str, velocity: float) -> ET.Element:
    joint = ET.Element("joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(joint, "axis", xyz=axis)
    ET.SubElement(
        joint,
        "limit",
        lower=f"{-BASE_LIMIT:g}",
        upper=f"{BASE_LIMIT:g}",
        effort=f"{BASE_EFFORT:g}",
        velocity=f"{velocity:g}",
    )
    return joint
