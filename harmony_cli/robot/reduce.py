"""Reducing a URDF to the joints a scenario uses: locked joints become fixed at their value, and fixed links merge
into their parents (inertia, visuals and collisions carried over) where the simulator cannot take them all."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from harmony_cli.robot.origin import joint_motion, origin_matrix, set_origin
from harmony_cli.robot.urdf import required

MOVING_CHILDREN = ("axis", "limit", "mimic", "dynamics", "calibration", "safety_controller")


def lock_joints(robot: ET.Element, values: dict[str, float]) -> None:
    """Turn each joint of `values` (name -> value [rad | m]) into a fixed joint holding that value."""
    for joint in robot.findall("joint"):
        name = joint.get("name")
        if name not in values:
            continue
        transform = origin_matrix(joint) @ joint_motion(joint, values[name])
        for tag in MOVING_CHILDREN:
            for child in joint.findall(tag):
                joint.remove(child)
        joint.set("type", "fixed")
        set_origin(joint, transform)


def merge_fixed_links(robot: ET.Element, keep: set[str]) -> list[str]:
    """Merge the child of every fixed joint into its parent unless the child is in `keep`; the merged links.

    Children first (a merged link's own fixed children have already moved into it), so one pass suffices."""
    links = {required(link, "name", "link"): link for link in robot.findall("link")}
    joints = robot.findall("joint")
    child_of = {required(j.find("child"), "link", "joint child"): j for j in joints}
    order = _depth_first(joints)
    merged = []
    for name in reversed(order):
        joint = child_of.get(name)
        if joint is None or joint.get("type") != "fixed" or name in keep:
            continue
        parent = required(joint.find("parent"), "link", "joint parent")
        _merge(links[parent], links[name], origin_matrix(joint))
        for other in robot.findall("joint"):
            if required(other.find("parent"), "link", "joint parent") == name:
                other.find("parent").set("link", parent)  # type: ignore[union-attr]
                set_origin(other, origin_matrix(joint) @ origin_matrix(other))
        robot.remove(joint)
        robot.remove(links[name])
        merged.append(name)
    return merged


def _depth_first(joints: list[ET.Element]) -> list[str]:
    """Link names, parents before children."""
    children: dict[str, list[str]] = {}
    for j in joints:
        parent = required(j.find("parent"), "link", "joint parent")
        children.setdefault(parent, []).append(required(j.find("child"), "link", "joint child"))
    every_child = {c for cs in children.values() for c in cs}
    stack, order = [p for p in children if p not in every_child], []
    while stack:
        link = stack.pop()
        order.append(link)
        stack.extend(reversed(children.get(link, [])))
    return order


def _merge(parent: ET.Element, child: ET.Element, transform: np.ndarray) -> None:
    """Move `child`'s visuals, collisions and inertia into `parent`; `transform` places child in parent."""
    for tag in ("visual", "collision"):
        for element in child.findall(tag):
            set_origin(element, transform @ origin_matrix(element))
            parent.append(element)
    masses = [m for m in (_inertia(parent, np.eye(4)), _inertia(child, transform)) if m is not None]
    if not masses:
        return
    mass = sum(m for m, _, _ in masses)
    com = np.sum([m * c for m, c, _ in masses], axis=0) / mass
    inertia = np.sum(
        [i + m * (np.dot(c - com, c - com) * np.eye(3) - np.outer(c - com, c - com)) for m, c, i in masses], axis=0
    )
    old = parent.find("inertial")
    if old is not None:
        parent.remove(old)
    inertial = ET.SubElement(parent, "inertial")
    ET.SubElement(inertial, "origin", xyz=" ".join(f"{v:.12g}" for v in com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=f"{mass:.12g}")
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    index = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    ET.SubElement(inertial, "inertia", {n: f"{inertia[i]:.12g}" for n, i in zip(names, index, strict=True)})


def _inertia(link: ET.Element, transform: np.ndarray) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(mass, centre of mass, inertia about it) in the frame `transform` maps the link into; None if massless."""
    inertial = link.find("inertial")
    if inertial is None or inertial.find("mass") is None:
        return None
    mass = float(required(inertial.find("mass"), "value", "mass"))
    frame = transform @ origin_matrix(inertial)
    element = inertial.find("inertia")
    get = (lambda k: float(element.get(k, 0.0))) if element is not None else (lambda k: 0.0)
    local = np.array(
        [
            [get("ixx"), get("ixy"), get("ixz")],
            [get("ixy"), get("iyy"), get("iyz")],
            [get("ixz"), get("iyz"), get("izz")],
        ]
    )
    return mass, frame[:3, 3], frame[:3, :3] @ local @ frame[:3, :3].T
