"""What robot packages ship and the parsers under harmony reject or misread, made explicit in the prepared copy.

- Top-level elements other than link / joint / material (<transmission>, <gazebo>, ...) are dropped: the URDF
  parser under OpTaS rejects a transmission without <type>, and no model harmony builds reads them.
- Looks the parsers cannot read are dropped: a <texture> without a file, a <color> that is not four numbers, a
  <material> without a name, a <visual> without one readable shape. They only colour or draw the robot; its
  kinematics, masses and collisions do not depend on them.
- A <robot> without a name gets its file's: urdf_parser_py requires one, and nothing harmony builds reads it.
- Continuous joints become revolute joints with limits of +-CONTINUOUS_LIMIT rad: OpTaS gives a continuous joint
  the limits [0, 0], which would pin it; PyBullet would too once locked.
- A link without <inertial> gets MASSLESS_LINK_MASS: PyBullet otherwise gives it 1 kg, Pinocchio 0 kg.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import Counter

from harmony_cli.robot.urdf import required
from harmony_cli.robot.urdf_form import numbers, shape_problem

KEPT_ELEMENTS = ("link", "joint", "material")
CONTINUOUS_LIMIT = 1000.0  # [rad]: no bound an MPC step or a simulation ever reaches
MASSLESS_LINK_MASS = 1e-3  # [kg] with a 1e-3 m radius of gyration
MASSLESS_LINK_INERTIA = MASSLESS_LINK_MASS * 1e-6


def strip_foreign_elements(robot: ET.Element) -> dict[str, int]:
    """Drop top-level elements no harmony model reads; tag -> how many were dropped."""
    dropped = [child for child in list(robot) if isinstance(child.tag, str) and child.tag not in KEPT_ELEMENTS]
    for child in dropped:
        robot.remove(child)
    return dict(Counter(str(child.tag) for child in dropped))


def name_robot(robot: ET.Element, name: str) -> bool:
    """Name a nameless <robot> `name`; True if it had no name."""
    if robot.get("name") is not None:
        return False
    robot.set("name", name)
    return True


def drop_unreadable_looks(robot: ET.Element) -> dict[str, int]:
    """Drop the textures, colours, materials and visuals the parsers cannot read; tag -> how many were dropped."""
    dropped: Counter[str] = Counter()

    def drop(parent: ET.Element, child: ET.Element) -> None:
        parent.remove(child)
        dropped[str(child.tag)] += 1

    for link in robot.findall("link"):
        for visual in link.findall("visual"):
            if shape_problem(visual):
                drop(link, visual)
    holders = [robot, *robot.findall("link/visual")]
    for material in [m for holder in holders for m in holder.findall("material")]:
        for texture in material.findall("texture"):
            if texture.get("filename") is None:
                drop(material, texture)
        for color in material.findall("color"):
            if not numbers(color.get("rgba", ""), 4):
                drop(material, color)
    for holder in holders:
        for material in holder.findall("material"):
            if material.get("name") is None:
                drop(holder, material)
    return dict(dropped)


def continuous_to_revolute(robot: ET.Element) -> list[str]:
    """Rewrite continuous joints as wide-limit revolute joints (effort and velocity kept); their names."""
    names = []
    for joint in robot.findall("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ET.SubElement(joint, "limit", effort="0", velocity="0")
        limit.set("lower", f"{-CONTINUOUS_LIMIT:g}")
        limit.set("upper", f"{CONTINUOUS_LIMIT:g}")
        names.append(required(joint, "name", "joint"))
    return names


def add_missing_inertials(robot: ET.Element, root_link: str) -> list[str]:
    """Give every link but the (world-fixed) root an <inertial> if it has none; their names."""
    names = []
    for link in robot.findall("link"):
        if link.find("inertial") is not None or link.get("name") == root_link:
            continue
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=f"{MASSLESS_LINK_MASS:g}")
        i = f"{MASSLESS_LINK_INERTIA:g}"
        ET.SubElement(inertial, "inertia", ixx=i, ixy="0", ixz="0", iyy=i, iyz="0", izz=i)
        names.append(required(link, "name", "link"))
    return names
