"""Reading a URDF's structure (joints, links, the tree): what scenario checks and robot set-up ask of it."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path


def required(element: ET.Element | None, attribute: str, where: str = "") -> str:
    """An attribute the URDF format requires; ValueError naming it when it is missing."""
    value = None if element is None else element.get(attribute)
    if value is None:
        raise ValueError(f"URDF {where or 'element'}: missing {attribute!r}")
    return value


def joints_and_links(urdf: Path) -> tuple[set[str], set[str]]:
    """The names of the model's joints and links: the <robot>'s own <joint> and <link> children, not elements of
    those tags inside extensions (<gazebo>, <transmission>, ...), which name or configure other things."""
    root = ET.parse(urdf).getroot()
    return (
        {required(j, "name", "joint") for j in root.findall("joint")},
        {required(link, "name", "link") for link in root.findall("link")},
    )


def joint_types(urdf: Path) -> dict[str, str]:
    """Joint name -> URDF type (revolute, continuous, prismatic, fixed, ...)."""
    return {required(j, "name", "joint"): str(j.get("type")) for j in ET.parse(urdf).getroot().findall("joint")}


def actuated_joint_names(urdf: Path) -> list[str]:
    """Names of the non-fixed joints of `urdf`, in file order (the order OpTaS uses)."""
    robot = ET.parse(urdf).getroot()
    return [required(joint, "name", "joint") for joint in robot.findall("joint") if joint.get("type") != "fixed"]


def parent_links(urdf: Path) -> dict[str, str]:
    """Child link -> parent link."""
    joints = ET.parse(urdf).getroot().findall("joint")
    return {
        required(j.find("child"), "link", "joint child"): required(j.find("parent"), "link", "joint parent")
        for j in joints
    }


def fixed_joints_above(urdf: Path, link: str) -> list[str]:
    """The fixed joints between `link` and the nearest movable joint above it, top first (the rigid wrist chain)."""
    joints = ET.parse(urdf).getroot().findall("joint")
    parent_joint = {required(joint.find("child"), "link", "joint child"): joint for joint in joints}
    chain: list[str] = []
    while link in parent_joint and parent_joint[link].get("type") == "fixed":
        chain.insert(0, required(parent_joint[link], "name", "joint"))
        link = required(parent_joint[link].find("parent"), "link", "joint parent")
    return chain


def hand_below(link: str, urdf: Path, end_effectors: dict[str, str]) -> str | None:
    """The one hand whose end-effector link is `link` or below it (None for a link above both hands, e.g. the
    chest, or on neither arm)."""
    parent = parent_links(urdf)

    def below(child: str | None) -> bool:
        while child is not None:
            if child == link:
                return True
            child = parent.get(child)
        return False

    hands = [hand for hand, ee in end_effectors.items() if below(ee)]
    return hands[0] if len(hands) == 1 else None


def wrist_sensor_joints(given: dict[str, str] | None, end_effectors: dict[str, str], urdf: Path) -> dict[str, str]:
    """Hand -> force/torque sensor joint, `given` or derived from the hand's end-effector link; ValueError
    (`field: value: reason; choices`) if unusable."""
    if given is not None and set(given) != set(end_effectors):
        raise ValueError(
            f"robot.wrist_sensors: {sorted(given)} must name every hand exactly once; hands: {', '.join(end_effectors)}"
        )
    sensors = {}
    for hand, link in end_effectors.items():
        choices = fixed_joints_above(urdf, link)
        if given is None:
            if not choices:
                raise ValueError(
                    f"robot.wrist_sensors: cannot derive hand {hand}'s sensor joint: {link!r} hangs "
                    f"from no fixed joint in {urdf.name}; add a fixed wrist joint to the URDF"
                )
            sensors[hand] = choices[-2] if len(choices) > 1 else choices[0]  # the joint above the frame's link
        elif given[hand] in choices:
            sensors[hand] = given[hand]
        else:
            raise ValueError(
                f"robot.wrist_sensors.{hand}: {given[hand]!r} is not a fixed joint between {link} and "
                f"the movable joint above it in {urdf.name}; choose one of: "
                f"{', '.join(choices) or '(none)'}"
            )
    return sensors
