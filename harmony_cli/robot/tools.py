"""Tool frames, declared in a scenario or by default at a hand link no fixed joint holds: per hand a pad (a thin box,
what touches the object) on a fixed joint below a link of the gripper, and the frame the MPCs control at the pad's
outer face, z along the pad normal (out of the hand). The pad's joint is the wrist sensor, so the sensed wrench is
what the object applies to the pad."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from harmony_cli.robot.origin import set_origin
from harmony_cli.robot.urdf import required

PAD = (0.06, 0.04, 0.01)  # [m] a pad's x, y and thickness unless the scenario gives them
PAD_DENSITY = 500.0  # [kg/m^3] a plastic pad: 60 x 40 x 10 mm weigh 12 g


def tool_link(hand: str) -> str:
    """The name of the frame a declared tool adds for `hand` (its end effector)."""
    return f"harmony_{hand}_tool"


def pad_joint(hand: str) -> str:
    return f"harmony_{hand}_pad_joint"


def bare_hands(robot: ET.Element, hands: dict[str, str]) -> dict[str, str]:
    """Hand -> link, of `hands` whose link hangs from a movable joint (or from none): no fixed joint above the link
    carries the wrist sensor, so such a hand gets a tool frame at its link itself, unless the scenario declares one."""
    parent_joint = {required(j.find("child"), "link", "joint child"): j for j in robot.findall("joint")}
    return {
        hand: link
        for hand, link in hands.items()
        if link not in parent_joint or parent_joint[link].get("type") != "fixed"
    }


def add_tool(robot: ET.Element, hand: str, parent: str, pose: np.ndarray, size: Sequence[float]) -> None:
    """Add `hand`'s pad link (fixed below `parent`, its outer face at `pose` in the parent's frame, `size` x, y,
    thickness) and its frame link at the pad's face."""
    pad_link, frame = f"harmony_{hand}_pad", tool_link(hand)
    taken = {str(link.get("name")) for link in robot.findall("link")} & {pad_link, frame}
    if taken:
        raise ValueError(f"robot.tools.{hand}: the URDF already has links named {sorted(taken)}")
    pad = ET.SubElement(robot, "link", name=pad_link)
    for tag in ("visual", "collision"):
        element = ET.SubElement(pad, tag)
        ET.SubElement(element, "origin", xyz=f"0 0 {-size[2] / 2:g}", rpy="0 0 0")
        ET.SubElement(ET.SubElement(element, "geometry"), "box", size=" ".join(f"{s:g}" for s in size))
    mass = PAD_DENSITY * size[0] * size[1] * size[2]
    inertial = ET.SubElement(pad, "inertial")
    ET.SubElement(inertial, "origin", xyz=f"0 0 {-size[2] / 2:g}", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=f"{mass:.6g}")
    a, b, c = (s * s for s in size)
    ET.SubElement(
        inertial,
        "inertia",
        ixx=f"{mass * (b + c) / 12:.6g}",
        iyy=f"{mass * (a + c) / 12:.6g}",
        izz=f"{mass * (a + b) / 12:.6g}",
        ixy="0",
        ixz="0",
        iyz="0",
    )
    ET.SubElement(robot, "link", name=frame)  # massless: sanitising gives it MASSLESS_LINK_MASS
    joint = ET.SubElement(robot, "joint", name=pad_joint(hand), type="fixed")
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=pad_link)
    set_origin(joint, pose)
    joint = ET.SubElement(robot, "joint", name=f"harmony_{hand}_tool_joint", type="fixed")
    ET.SubElement(joint, "parent", link=pad_link)
    ET.SubElement(joint, "child", link=frame)
    ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")
