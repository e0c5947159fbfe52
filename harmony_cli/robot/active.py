"""Which of a URDF's movable joints the MPCs use, and what becomes of the others.

By default: the joints on the kinematic chains from the URDF's root to each hand's link (for a hand with a declared
tool, the tool's parent link), and the joints the robot section gives a role (chest, pinned, mirrored). These are
the joints that move the hands, plus the ones the section names. A plan without hands has no chains to follow
and takes every movable joint. An explicit list of names or fnmatch patterns (robot.active_joints) wins. Base
joints are always active and are not counted here.

Mimic joints follow their leader (robot/mimic.py). A follower whose leader is active is coupled: it moves with
the leader. One whose leader is locked is locked at the leader's locked value. By default a follower on a chain
makes its leader active, because the follower moves the hand and can only do so through its leader. In an
explicit list a follower is named with its leader or not at all, and a listed leader takes its followers along.
Every other movable joint is locked at its home value.
"""

from __future__ import annotations

import fnmatch
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from harmony_cli.names import closest
from harmony_cli.robot.mimic import Mimic, mimic_joints
from harmony_cli.robot.urdf import required

HOME_TOLERANCE = 1e-9  # [rad | m] a home value's rounding: past a limit, or off a follower's coupling, by this


@dataclass(frozen=True)
class JointSelection:
    """The movable joints of a URDF (base joints aside), each active, coupled or locked."""

    active: tuple[str, ...]  # the joints the MPCs use, in URDF order (followers aside)
    coupled: dict[str, Mimic]  # followers of an active leader: they move with it
    locked: dict[str, float]  # every other movable joint, fixed at this value [rad | m]
    by_default: bool  # the chains to the hands chose `active` (no explicit list)


def select_joints(
    robot: ET.Element,
    patterns: tuple[str, ...] | None,
    hands: dict[str, str],
    roles: tuple[str, ...],
    base_joints: tuple[str, ...],
    home: dict[str, float],
    urdf: Path,
) -> JointSelection:
    """The joints `patterns` match, or when None the chains to `hands` (field -> link, e.g. `end_effectors.left`)
    and the `roles`' joints; followers coupled to an active leader, everything else locked at `home` [rad | m].
    ValueError (`robot.<field>: ...`) for a pattern matching nothing, a follower listed without its leader, a hand
    link the URDF lacks and a follower's home off its leader's."""
    mimics = mimic_joints(robot)
    movable = [
        required(j, "name", "joint")
        for j in robot.findall("joint")
        if j.get("type") != "fixed" and j.get("name") not in base_joints
    ]
    if patterns is None:
        chosen = chain_joints(robot, hands, urdf) | set(roles) if hands else set(movable)
        chosen |= {mimics[j].master for j in chosen if j in mimics}
    else:
        chosen = _listed(movable, patterns, mimics, urdf)
    active = tuple(j for j in movable if j in chosen and j not in mimics)
    coupled = {j: m for j, m in mimics.items() if j in movable and m.master in active}
    locked = {j: home.get(j, 0.0) for j in movable if j not in active and j not in mimics}
    locked |= {
        j: m.value(locked.get(m.master, home.get(m.master, 0.0)))
        for j, m in mimics.items()
        if j in movable and j not in coupled
    }
    for joint, mimic in mimics.items():
        expected = mimic.value(home.get(mimic.master, 0.0))
        if joint in home and abs(home[joint] - expected) > HOME_TOLERANCE:
            raise ValueError(
                f"robot.home.{joint}: {joint!r} mimics {mimic.master!r} (its value is {mimic.multiplier:g} x "
                f"{mimic.master} + {mimic.offset:g}); leave it out of robot.home and give {mimic.master!r}'s"
            )
    return JointSelection(active, coupled, locked, patterns is None)


def chain_joints(robot: ET.Element, hands: dict[str, str], urdf: Path) -> set[str]:
    """The movable joints on the chains from the root down to each of `hands`' links (field -> link)."""
    parent_joint = {required(j.find("child"), "link", "joint child"): j for j in robot.findall("joint")}
    links = {required(link, "name", "link") for link in robot.findall("link")}
    joints: set[str] = set()
    for field, link in hands.items():
        if link not in links:
            raise ValueError(f"robot.{field}: {link!r} is not a link of {urdf.name}; {closest(link, links)}")
        seen = {link}
        while link in parent_joint:
            joint = parent_joint[link]
            if joint.get("type") != "fixed":
                joints.add(required(joint, "name", "joint"))
            link = required(joint.find("parent"), "link", "joint parent")
            if link in seen:  # a malformed URDF's loop: the chain ends where it closes
                break
            seen.add(link)
    return joints


def _listed(movable: list[str], patterns: tuple[str, ...], mimics: dict[str, Mimic], urdf: Path) -> set[str]:
    """The movable joints `patterns` match; ValueError for a pattern matching none or a follower without its
    leader."""
    for pattern in patterns:
        if not fnmatch.filter(movable, pattern):
            raise ValueError(
                f"robot.active_joints: {pattern!r} matches no movable joint of {urdf.name}; {closest(pattern, movable)}"
            )
    chosen = {j for j in movable if any(fnmatch.fnmatchcase(j, p) for p in patterns)}
    for joint in sorted(chosen & mimics.keys(), key=movable.index):
        leader = mimics[joint].master
        if leader not in chosen:
            raise ValueError(
                f"robot.active_joints: {joint!r} mimics {leader!r}, which is not listed; list {leader!r} too (the "
                f"follower then moves with it) or leave {joint!r} out (it is then locked, following {leader!r})"
            )
    return chosen
