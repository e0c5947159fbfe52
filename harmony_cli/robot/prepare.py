"""Make a robot package's URDF loadable by harmony, as a prepared copy in the cache.

In order: elements and joint types the parsers reject or misread are made explicit (robot/sanitize.py) and what
remains is checked for their form (robot/urdf_form.py); the joints a scenario does not use (by default those off
the chains to the hands, robot/active.py) are locked, fixed at their home value (mimic joints at their leader's;
kept movable, <mimic> and all, when the leader is active: robot/mimic.py); tool frames are added, declared ones and
one at each hand link no fixed joint holds (robot/tools.py); mesh filenames become absolute paths, so the copy can
live in the cache (and `mount: auto` can load the meshes, robot/ground.py); the virtual planar base goes above the
root, the root mounted on it (robot/placement.py); links without inertia get a small one; fixed links merge into
their parents when PyBullet could not take them all (robot/reduce.py).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.names import closest
from harmony_cli.robot.active import HOME_TOLERANCE, select_joints
from harmony_cli.robot.ground import Lowest, UnreadableUrdf, resting_mount
from harmony_cli.robot.mimic import Mimic
from harmony_cli.robot.origin import pose_matrix
from harmony_cli.robot.placement import ensure_base_joints, root_link_of
from harmony_cli.robot.reduce import lock_joints, merge_fixed_links
from harmony_cli.robot.sanitize import (
    add_missing_inertials,
    continuous_to_revolute,
    drop_unreadable_looks,
    name_robot,
    strip_foreign_elements,
)
from harmony_cli.robot.tools import PAD, add_tool, bare_hands, tool_link
from harmony_cli.robot.urdf import required
from harmony_cli.robot.urdf_form import check_form

if TYPE_CHECKING:
    from harmony_cli.scenario.robot import ToolSpec

PACKAGE_SCHEME = "package://"
PYBULLET_MAX_JOINTS = 127  # state queries fail at >= 128 links (bullet3 MAX_DEGREE_OF_FREEDOM, SharedMemoryCommands.h)
AUTO = "auto"  # a mount that rests the robot on the ground (robot/ground.py)
Mount = tuple[list[float], list[float]]  # xyz [m], rpy [deg] of the root link on the virtual base


@dataclass(frozen=True)
class UrdfPlan:
    """What a scenario asks of the URDF, in the URDF's own names."""

    base_joints: tuple[str, ...] = ("base_x", "base_y", "base_yaw")
    package_paths: tuple[Path, ...] = ()
    active: tuple[str, ...] | None = None  # fnmatch patterns of the joints the MPCs use; None: the chains to the
    # hands and the roles' joints (robot/active.py)
    roles: tuple[str, ...] = ()  # joints the robot section gives a role (chest, pinned, mirrored)
    home: dict[str, float] = field(default_factory=dict)  # [deg] revolute and continuous, [m] prismatic
    tools: dict[str, ToolSpec] = field(default_factory=dict)
    mount: Mount | str | None = None  # the root on the base; AUTO: resting on the ground; None: at the base
    keep: tuple[str, ...] = ()  # links that must stay links (end effectors, pushed links)
    hands: dict[str, str] = field(default_factory=dict)  # hand -> end-effector link (a tool frame at it: see tools.py)


@dataclass(frozen=True)
class PreparedUrdf:
    """The prepared URDF and what preparing it changed."""

    path: Path
    home: dict[str, float]  # every joint the plan's home names [rad | m]; continuous joints wrapped to (-pi, pi]
    continuous: tuple[str, ...]  # now revolute joints with wide limits
    locked: dict[str, float]  # now fixed joints, at these values [rad | m]
    dropped: dict[str, int]  # element tag -> how many were dropped (foreign top-level ones, unreadable looks)
    massless: tuple[str, ...]  # links given a small inertia
    merged: tuple[str, ...]  # links merged into their parents
    hand_tools: tuple[str, ...] = ()  # hands given a tool frame at their link (no fixed joint holds it)
    mount: Mount | None = None  # the root on the virtual base (AUTO resolved); None: at the base's origin
    rested: Lowest | None = None  # the lowest point AUTO lifted onto the ground (None: it did not lift)
    coupled: dict[str, Mimic] = field(default_factory=dict)  # mimic joints moving with an active leader
    by_default: bool = True  # the chains to the hands chose the active joints (no robot.active_joints)

    def notes(self) -> list[str]:
        """One line per kind of change, for run.log and `harmony robots show`."""
        kinds = {
            "dropped elements": [f"{tag} x{n}" for tag, n in self.dropped.items()],
            "continuous joints (unbounded revolute)": list(self.continuous),
            f"locked joints ({'off the chains to the hands' if self.by_default else 'not in robot.active_joints'})": [
                f"{j}={v:.4g}" for j, v in self.locked.items()
            ],
            "mimic joints moving with their leader": [
                f"{j}={m.multiplier:g}*{m.master}{m.offset:+g}" for j, m in self.coupled.items()
            ],
            "links given a small inertia": list(self.massless),
            "fixed links merged into their parents": list(self.merged),
            "tool frames at the hand link (a movable joint holds it)": list(self.hand_tools),
        }
        notes = [f"urdf: {kind}: {len(items)}: {', '.join(items)}" for kind, items in kinds.items() if items]
        if self.rested is not None and self.mount is not None:
            notes.append(
                f"urdf: mount: auto: the root raised {self.mount[0][2]:.4f} m, to rest link {self.rested.link}'s "
                "lowest collision point at home on the ground"
            )
        return notes


def prepare_urdf(urdf: Path, plan: UrdfPlan, cache_dir: Path) -> PreparedUrdf:
    """Prepare `urdf` for `plan`; the original path comes back when nothing had to change, otherwise the copy
    written to `cache_dir` as `<stem>_<content hash>.urdf`. ValueError (`robot.<field>: ...`) for what cannot be."""
    original, urdf = Path(urdf), Path(urdf).resolve()
    robot, dropped, named = _model(urdf)
    home = home_values(robot, plan.home, urdf, plan.base_joints)
    chains = {f"tools.{hand}.parent": tool.parent for hand, tool in plan.tools.items()}
    chains |= {f"end_effectors.{hand}": link for hand, link in plan.hands.items() if hand not in plan.tools}
    joints = select_joints(robot, plan.active, chains, plan.roles, plan.base_joints, home, urdf)
    home |= {j: m.value(home.get(m.master, 0.0)) for j, m in joints.coupled.items()}
    locked = joints.locked
    lock_joints(robot, locked)
    continuous = continuous_to_revolute(robot)
    for hand, tool in plan.tools.items():
        add_tool(robot, hand, tool.parent, pose_matrix(tool.xyz, np.deg2rad(tool.rpy_deg)), tool.pad)
    hand_tools = bare_hands(robot, {hand: link for hand, link in plan.hands.items() if hand not in plan.tools})
    for hand, link in hand_tools.items():
        add_tool(robot, hand, link, np.eye(4), PAD)
    meshes = _resolve_mesh_filenames(robot, urdf, list(plan.package_paths))
    try:
        mount, rested = _mount(robot, plan, home)
    except UnreadableUrdf as err:
        raise ValueError(f"robot.urdf: {urdf.name}: {err}") from None
    added_base = ensure_base_joints(robot, urdf, plan.base_joints, mount)
    massless = add_missing_inertials(robot, root_link_of(robot, urdf))
    merged = []
    if len(robot.findall("joint")) > PYBULLET_MAX_JOINTS:
        merged = merge_fixed_links(robot, _fixed_chains(robot, plan.keep + tuple(map(tool_link, hand_tools))))
    path = original
    changed = dropped or named or locked or continuous or plan.tools or hand_tools or added_base or massless or merged
    if changed or meshes:
        ET.indent(robot, space="  ")
        path = _write_cached(f'<?xml version="1.0"?>\n{ET.tostring(robot, encoding="unicode")}\n', urdf.stem, cache_dir)
    return PreparedUrdf(
        path,
        home,
        tuple(continuous),
        locked,
        dropped,
        tuple(massless),
        tuple(merged),
        tuple(hand_tools),
        mount,
        rested,
        joints.coupled,
        joints.by_default,
    )


def _model(urdf: Path) -> tuple[ET.Element, dict[str, int], bool]:
    """`urdf`'s <robot> with what the parsers reject or misread made explicit and its form checked; the elements
    dropped (tag -> how many) and whether the robot had to be named. ValueError (`robot.urdf: ...`) for a
    malformed one."""
    robot = ET.parse(urdf, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))).getroot()
    dropped = dict(Counter(strip_foreign_elements(robot)) + Counter(drop_unreadable_looks(robot)))
    named = name_robot(robot, urdf.stem)
    try:
        check_form(robot)
    except ValueError as err:
        raise ValueError(f"robot.urdf: {urdf.name}: {err}") from None
    return robot, dropped, named


def _mount(robot: ET.Element, plan: UrdfPlan, home: dict[str, float]) -> tuple[Mount | None, Lowest | None]:
    """The root's pose on the virtual base: the plan's, or for AUTO the one resting the robot on the ground (none
    when the URDF has base joints of its own: they place the root); and the lowest point AUTO lifted."""
    if not isinstance(plan.mount, str):  # the only string is AUTO
        return plan.mount, None
    if {joint.get("name") for joint in robot.findall("joint")} & set(plan.base_joints):
        return None, None
    mount, lowest = resting_mount(robot, home)
    return mount, lowest if mount is not None else None


def home_values(
    robot: ET.Element, home: dict[str, float], urdf: Path, base_joints: tuple[str, ...] = ()
) -> dict[str, float]:
    """The home pose in SI units: degrees -> rad for revolute and continuous joints (continuous ones wrapped),
    metres for prismatic ones; ValueError for a fixed or unknown joint or a value outside the joint's limits."""
    joints = {required(j, "name", "joint"): j for j in robot.findall("joint")}
    values = {}
    for name, given in home.items():
        if name in base_joints:
            raise ValueError(f"robot.home.{name}: a base joint; give the base's start as robot.base_pose [x, y, yaw]")
        joint = joints.get(name)
        if joint is None:
            raise ValueError(f"robot.home.{name}: not a joint of {urdf.name}; {closest(name, joints)}")
        kind, limit = joint.get("type"), joint.find("limit")
        if kind not in ("revolute", "continuous", "prismatic"):
            raise ValueError(f"robot.home.{name}: a {kind} joint has no home; name a movable joint")
        value = given if kind == "prismatic" else float(np.deg2rad(given))
        if kind == "continuous":
            value = float(np.pi - (np.pi - value) % (2 * np.pi))
        elif limit is not None:
            lower, upper = float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0))
            if not lower - HOME_TOLERANCE <= value <= upper + HOME_TOLERANCE:
                unit, scale = ("m", 1.0) if kind == "prismatic" else ("deg", 180 / np.pi)
                raise ValueError(
                    f"robot.home.{name}: {given:g} {unit} is outside the joint's limits "
                    f"[{lower * scale:.4g}, {upper * scale:.4g}] {unit}"
                )
        values[name] = value
    return values


def _fixed_chains(robot: ET.Element, links: tuple[str, ...]) -> set[str]:
    """`links` and every link above them up to the nearest movable joint (the wrist chains stay whole)."""
    parent_joint = {required(j.find("child"), "link", "joint child"): j for j in robot.findall("joint")}
    kept = set()
    for link in links:
        kept.add(link)
        while link in parent_joint and parent_joint[link].get("type") == "fixed":
            link = required(parent_joint[link].find("parent"), "link", "joint parent")
            kept.add(link)
    return kept


def _resolve_mesh_filenames(robot: ET.Element, urdf: Path, package_paths: list[Path]) -> bool:
    """Rewrite package:// and relative mesh filenames as absolute paths; True if any changed. FileNotFoundError
    (`robot.urdf: ...`) for a mesh file that is not there: PyBullet would refuse the whole URDF without naming it."""
    changed = False
    for mesh in robot.iter("mesh"):
        filename = mesh.get("filename", "")
        if "://" in filename and not filename.startswith(PACKAGE_SCHEME):
            continue
        resolved = _mesh_file(filename, urdf, package_paths)
        if resolved != filename:
            mesh.set("filename", resolved)
            changed = True
    return changed


def _mesh_file(filename: str, urdf: Path, package_paths: list[Path]) -> str:
    """The file a mesh filename names: a package:// URI as the first existing `<search>/<pkg>/<rest>` or
    `<search>/<rest>` over the search paths, a relative path from the URDF's folder, an absolute one as it is."""
    if filename.startswith(PACKAGE_SCHEME):
        package, _, rest = filename[len(PACKAGE_SCHEME) :].partition("/")
        candidates = [c for search in package_paths for c in (search / package / rest, search / rest)]
    else:
        candidates = [urdf.parent / filename]
    for candidate in candidates:
        if candidate.is_file():
            return filename if Path(filename).is_absolute() else str(candidate.resolve())
    tried = ", ".join(map(str, candidates)) or "no robot.package_paths"
    raise FileNotFoundError(f"robot.urdf: {urdf.name}: mesh {filename!r} not found; tried {tried}")


def _write_cached(text: str, stem: str, cache_dir: Path) -> Path:
    """Write `text` atomically as `<stem>_<sha256[:16]>.urdf` in `cache_dir` (kept if present)."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    target = cache_dir / f"{stem}_{digest}.urdf"
    if target.is_file():
        return target
    cache_dir.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=cache_dir, prefix=f".{stem}_", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp_name, target)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return target
