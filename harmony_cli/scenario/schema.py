"""Scenario schema versions: 2 is the current one; 1 is the one before robot presets. A file states its
schema with `schema: N`; one that does not is of schema 1 if it holds one of schema 1's fields, else current, so a
current file needs no key and an old one is told apart by what it holds. A file of schema 1 loads with its old fields
read as their new forms and a one-line notice naming each; `harmony upgrade` rewrites it (scenario/upgrade.py).

Schema 1's fields and their schema-2 forms:
- `robot.home_deg` -> `robot.home`: the same numbers for revolute and continuous joints (degrees); a prismatic
  joint's number was read as degrees too (turned into radians and used as metres), so it becomes that many metres;
  the base joints' numbers become `robot.base_pose` (schema 2 starts the base there, not at a home).
- `robot.urdf` naming EVA's URDF where it lay before presets (`.../robots/eva.urdf`, `.../profiles/eva.urdf`, no
  longer there) -> `robot.preset: eva`, and twin_arm's (`.../robots/twin_arm.urdf`) -> `robot.preset: twin_arm`;
  a section with EVA's URDF took EVA's defaults (hands, head, home, footprint), which is what the preset gives.
- `robot.profile` -> `robot.preset`; `sim.actuators` -> `robot.actuators`."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path, PurePosixPath
from typing import Any

from harmony_cli.robot.presets import PresetUnavailable, available_presets, load_preset
from harmony_cli.robot.urdf import joint_types
from harmony_cli.scenario.checks import check_urdf, urdf_file
from harmony_cli.scenario.errors import ScenarioError, brief
from harmony_cli.scenario.robot import DEFAULT_PRESET
from harmony_cli.scenario.yaml_edit import Edit, apply_to_data

CURRENT = 2
KNOWN = {1: "deprecated", 2: "current"}
# the last two parts of the paths the URDFs that became presets had (a scenario named them relative to itself)
MOVED_URDFS: dict[tuple[str, ...], str] = {
    ("robots", "eva.urdf"): "eva",  # scenarios/robots/eva.urdf, until the package was laid out by role
    ("profiles", "eva.urdf"): "eva",  # harmony_cli/robot/profiles/eva.urdf, until presets
    ("robots", "twin_arm.urdf"): "twin_arm",  # scenarios/robots/twin_arm.urdf, until presets
}
BASE_JOINTS = (("base_x", "prismatic"), ("base_y", "prismatic"), ("base_yaw", "revolute"))  # what harmony adds


def stated_schema(raw: dict, path: Path) -> int | None:
    """The schema a file states (None: it states none); ScenarioError listing the known ones for any other value."""
    if "schema" not in raw:
        return None
    value = raw["schema"]
    if type(value) is not int or value not in KNOWN:
        known = ", ".join(f"{n} ({what})" for n, what in KNOWN.items())
        raise ScenarioError(f"{path}: schema: {brief(value)} is not a known schema; choose one of: {known}")
    return value


def moved_preset(urdf: Any, folder: Path) -> str | None:
    """The preset a robot.urdf of schema 1 means: one naming where EVA's or twin_arm's URDF lay, not there now."""
    if not isinstance(urdf, str):
        return None
    name = MOVED_URDFS.get(PurePosixPath(urdf).parts[-2:])
    try:
        return name if name is not None and not (folder / urdf).exists() else None
    except (OSError, ValueError):  # not a usable path: the URDF check says so
        return None


def _preset_edits(robot: dict, folder: Path) -> tuple[list[Edit], list[str]]:
    """`profile` -> `preset`, and a moved URDF's path -> the preset it became."""
    edits, renamed = [], []
    named = "preset" if "preset" in robot else None
    if "profile" in robot and named is None:
        edits.append(Edit("rename", ("robot", "profile"), "preset"))
        renamed.append("robot.profile -> robot.preset")
        named = "profile"
    preset = moved_preset(robot.get("urdf"), folder)
    if preset is not None:
        renamed.append(f"robot.urdf {robot['urdf']!r} (moved) -> robot.preset: {preset}")
        if named is None:  # the entry becomes `preset: NAME` where it stands
            edits += [Edit("set", ("robot", "urdf"), preset), Edit("rename", ("robot", "urdf"), "preset")]
        else:  # the URDF names the robot: the preset is its
            edits.append(Edit("delete", ("robot", "urdf")))
            if robot[named] != preset:
                edits.append(Edit("set", ("robot", named), preset))
    return edits, renamed


def _urdf_of(robot: dict, path: Path) -> Path | None:
    """The URDF a (schema-2) robot section names: its own, else its preset's; None for an unknown preset."""
    if isinstance(robot.get("urdf"), str):
        return urdf_file(path, robot["urdf"])
    name = robot.get("preset", DEFAULT_PRESET)
    if name not in available_presets():
        return None
    try:
        return Path(load_preset(name)["urdf"])
    except PresetUnavailable as err:
        raise ScenarioError(f"{path}: robot.preset: {err}") from None


def _joint_types(robot: dict, path: Path) -> dict[str, str]:
    """Joint -> URDF type of the robot a section names, with the planar base harmony adds when the URDF has none."""
    urdf = _urdf_of(robot, path)
    if urdf is None:
        return {}
    check_urdf(path, urdf)
    try:
        types = joint_types(urdf)
    except (ET.ParseError, ValueError) as err:
        raise ScenarioError(f"{path}: robot.urdf: {urdf.name} is not a readable URDF: {err}") from None
    base = base_joints(robot)
    if base and not set(base) & set(types):
        types |= {name: kind for name, (_, kind) in zip(base, BASE_JOINTS, strict=True)}
    return types


def base_joints(robot: dict) -> list[str]:
    """The base joints a robot section names (none if they are not three names: validation says why)."""
    base = robot.get("base_joints", [name for name, _ in BASE_JOINTS])
    valid = isinstance(base, list) and len(base) == len(BASE_JOINTS) and all(isinstance(n, str) for n in base)
    return base if valid else []


def _base_start(robot: dict, upgraded: dict, start: dict) -> tuple[list[Edit], str]:
    """Base joints' homes -> `robot.base_pose` [x m, y m, yaw deg] (schema 2 starts the base there): x and y were
    read as degrees (in radians, used as metres), the yaw in degrees."""
    x, y, yaw = (start.get(name, 0) for name in base_joints(upgraded))
    pose = [math.radians(x), math.radians(y), float(yaw)]
    edits = [Edit("insert", ("robot", "base_pose"), pose)]
    if len(start) == len(robot["home_deg"]):  # nothing else: an empty mapping, not an empty (null) block
        edits.append(Edit("set", ("robot", "home_deg"), {}))
    else:
        edits += [Edit("delete", ("robot", "home_deg", joint)) for joint in start]
    return edits, f"{', '.join(map(str, start))} -> robot.base_pose [{', '.join(f'{v:.6g}' for v in pose)}]"


def _home_edits(robot: dict, upgraded: dict, path: Path) -> tuple[list[Edit], list[str]]:
    """`home_deg` -> `home`; a prismatic joint's number x (read as x degrees, in radians, used as metres) ->
    radians(x) metres, and the base joints' -> `base_pose`, so the robot starts where it did."""
    edits, notes = [Edit("rename", ("robot", "home_deg"), "home")], []
    home = robot["home_deg"]
    numbers = {j: v for j, v in home.items() if type(v) in (int, float)} if isinstance(home, dict) else {}
    start = {j: v for j, v in numbers.items() if j in base_joints(upgraded)}
    if start and "base_pose" not in robot:
        more, note = _base_start(robot, upgraded, start)
        edits, notes = edits + more, [note]
    others = {j: v for j, v in numbers.items() if j not in start}
    types = _joint_types(upgraded, path) if others else {}
    metres = {joint: value for joint, value in others.items() if types.get(str(joint)) == "prismatic"}
    edits += [Edit("set", ("robot", "home_deg", joint), math.radians(value)) for joint, value in metres.items()]
    if metres:
        changed = ", ".join(f"{joint}: {value:g} -> {math.radians(value):.6g}" for joint, value in metres.items())
        notes.append(f"prismatic joints in metres: {changed}")
    return edits, ["robot.home_deg -> robot.home" + (f" ({'; '.join(notes)})" if notes else "")]


def _actuator_edits(raw: dict) -> tuple[list[Edit], list[str]]:
    """`sim.actuators` -> `robot.actuators` (a `sim` section left empty goes)."""
    sim, robot = raw.get("sim"), raw.get("robot")
    if not (isinstance(sim, dict) and "actuators" in sim) or (isinstance(robot, dict) and "actuators" in robot):
        return [], []
    value = sim["actuators"]
    if isinstance(robot, dict):
        put = Edit("insert", ("robot", "actuators"), value)
    elif "robot" not in raw or robot is None:
        put = Edit("set" if "robot" in raw else "insert", ("robot",), {"actuators": value})
    else:  # not a section: validation says so
        return [], []
    drop = Edit("delete", ("sim",) if len(sim) == 1 else ("sim", "actuators"))
    return [put, drop], ["sim.actuators -> robot.actuators"]


def schema_edits(raw: dict, path: Path) -> tuple[list[Edit], list[str]]:
    """The edits that make a scenario mapping current, and each renamed field as `old -> new` (none for a current
    file); ScenarioError for a schema it does not know, or a URDF missing where a renamed field needs it."""
    stated = stated_schema(raw, path)
    if stated == CURRENT:
        return [], []
    edits: list[Edit] = []
    renamed: list[str] = []
    robot = raw.get("robot")
    if isinstance(robot, dict):
        edits, renamed = _preset_edits(robot, path.parent)
        if "home_deg" in robot and "home" not in robot:
            upgraded = apply_to_data({"robot": robot}, edits)["robot"]
            more, notes = _home_edits(robot, upgraded, path)
            edits, renamed = edits + more, renamed + notes
    more, notes = _actuator_edits(raw)
    edits, renamed = edits + more, renamed + notes
    if stated is not None:
        return [*edits, Edit("set", ("schema",), CURRENT)], [*renamed, f"schema: {stated} -> {CURRENT}"]
    if edits:
        edits.append(Edit("insert", ("schema",), CURRENT, first=True))
    return edits, renamed


def as_current(raw: dict, path: Path, notices: list[str] | None = None) -> dict:
    """A scenario mapping of any known schema as the current one; for an older one, a one-line deprecation notice
    naming each renamed field is appended to `notices`."""
    edits, renamed = schema_edits(raw, path)
    if renamed and notices is not None:
        notices.append(
            f"{path}: schema 1 is deprecated; read as schema {CURRENT}: {'; '.join(renamed)} "
            f"(`harmony upgrade {path}` rewrites the file)"
        )
    return apply_to_data(raw, edits) if edits else raw
