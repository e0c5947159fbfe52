"""Reading a URDF's structure (joints, links, the tree): what scenario checks and robot set-up ask of it."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from harmony_cli.scenario.robot import RobotSpec


def joints_and_links(urdf: Path) -> tuple[set[str], set[str]]:
    root = ET.parse(urdf).getroot()
    return {j.get("name") for j in root.iter("joint")}, {link.get("name") for link in root.iter("link")}


def actuated_joint_names(urdf: Path) -> list[str]:
    """Names of the non-fixed joints of `urdf`, in file order (the order OpTaS uses)."""
    robot = ET.parse(urdf).getroot()
    return [joint.get("name") for joint in robot.findall("joint") if joint.get("type") != "fixed"]


def parent_links(urdf: Path) -> dict[str, str]:
    """Child link -> parent link."""
    return {
        j.find("child").get("link"): j.find("parent").get("link") for j in ET.parse(urdf).getroot().findall("joint")
    }


def fixed_joints_above(urdf: Path, link: str) -> list[str]:
    """The fixed joints between `link` and the nearest movable joint above it, top first (the rigid wrist chain)."""
    parent_joint = {joint.find("child").get("link"): joint for joint in ET.parse(urdf).getroot().findall("joint")}
    chain = []
    while link in parent_joint and parent_joint[link].get("type") == "fixed":
        chain.insert(0, parent_joint[link].get("name"))
        link = parent_joint[link].find("parent").get("link")
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


def wrist_sensor_joints(spec: RobotSpec, urdf: Path) -> dict[str, str]:
    """Hand -> force/torque sensor joint, given or derived; ValueError (`field: value: reason; choices`) if unusable."""
    given = spec.wrist_sensors
    if given is not None and set(given) != set(spec.end_effectors):
        raise ValueError(
            f"robot.wrist_sensors: {sorted(given)} must name every hand exactly once; "
            f"hands: {', '.join(spec.end_effectors)}"
        )
    sensors = {}
    for hand, link in spec.end_effectors.items():
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
