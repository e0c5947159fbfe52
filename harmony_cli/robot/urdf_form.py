"""The form a URDF's model elements must have for the parsers under harmony (urdf_parser_py under OpTaS, urdfdom
under Pinocchio, PyBullet's own) to read them, checked before any of them does: a malformed file is refused in one
line naming the element, what is wrong and the valid forms, not with a parser's traceback. What a parser still
refuses past these checks comes back as one line too (`refused_by`)."""

from __future__ import annotations

import contextlib
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
LIMITED_TYPES = ("revolute", "prismatic")  # urdfdom refuses them without a <limit>
SHAPES = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",), "mesh": ("filename",)}
REQUIRED = {
    "limit": ("effort", "velocity"),
    "mass": ("value",),
    "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
    "mimic": ("joint",),
    "safety_controller": ("k_velocity",),
    "color": ("rgba",),
    "texture": ("filename",),
    "material": ("name",),
    **SHAPES,
}
NUMBERS = {  # tag -> attribute -> how many numbers it holds
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": {"lower": 1, "upper": 1, "effort": 1, "velocity": 1},
    "mass": {"value": 1},
    "inertia": dict.fromkeys(REQUIRED["inertia"], 1),
    "mimic": {"multiplier": 1, "offset": 1},
    "dynamics": {"damping": 1, "friction": 1},
    "box": {"size": 3},
    "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1},
    "mesh": {"scale": 3},
    "color": {"rgba": 4},
}


def shape_problem(element: ET.Element) -> str | None:
    """What keeps a <visual> or <collision> from having one shape the parsers read (None: nothing)."""
    geometry = element.find("geometry")
    shapes = [] if geometry is None else [child for child in geometry if isinstance(child.tag, str)]
    choices = ", ".join(f"{shape} ({' and '.join(needs)})" for shape, needs in SHAPES.items())
    if len(shapes) != 1 or shapes[0].tag not in SHAPES:
        found = ", ".join(f"<{s.tag}>" for s in shapes) or "none"
        return f"<{element.tag}> needs one <geometry> shape (found {found}); choose one of: {choices}"
    missing = [name for name in SHAPES[shapes[0].tag] if shapes[0].get(name) is None]
    if missing:
        return (
            f"<{element.tag}>: <{shapes[0].tag}> has no {' and '.join(missing)}; shapes and what they need: {choices}"
        )
    return None


def check_form(robot: ET.Element) -> None:
    """Refuse (ValueError, one line) a <robot> whose links, joints or materials the parsers cannot read."""
    for tag in ("link", "joint"):
        twice = [n for n, count in Counter(e.get("name") for e in robot.findall(tag)).items() if count > 1]
        if twice:
            raise ValueError(f"{tag} {twice[0]!r} is defined more than once; names must be unique")
    for element in robot:
        if element.tag in ("link", "joint") and element.get("name") is None:
            raise ValueError(f"a <{element.tag}> has no name; the URDF format requires one")
        if isinstance(element.tag, str):
            where = f"{element.tag} {element.get('name')!r}"
            for part in element.iter():
                _check_attributes(part, where)
            for collision in element.findall("collision"):
                problem = shape_problem(collision)
                if problem:
                    raise ValueError(f"{where}: {problem}")
            if element.tag == "joint":
                _check_joint(element, where)


def _check_joint(joint: ET.Element, where: str) -> None:
    kind = joint.get("type")
    if kind not in JOINT_TYPES:
        problem = "has no type" if kind is None else f"type {kind!r} is not a URDF joint type"
        raise ValueError(f"{where}: {problem}; choose one of: {', '.join(JOINT_TYPES)}")
    if kind in LIMITED_TYPES and joint.find("limit") is None:
        raise ValueError(f"{where}: a {kind} joint needs a <limit> (lower, upper, effort, velocity)")
    axis = joint.find("axis")
    if axis is not None and kind != "fixed" and not any(float(x) for x in axis.get("xyz", "1 0 0").split()):
        raise ValueError(f"{where}: <axis> xyz={axis.get('xyz')!r} has no direction; give a non-zero vector")


def _check_attributes(element: ET.Element, where: str) -> None:
    """The attributes `element` must have are there, and those holding numbers hold as many as they should."""
    tag = str(element.tag)
    missing = [name for name in REQUIRED.get(tag, ()) if element.get(name) is None]
    if missing:
        raise ValueError(f"{where}: <{tag}> has no {', '.join(missing)}; the URDF format requires it")
    for name, count in NUMBERS.get(tag, {}).items():
        text = element.get(name)
        if text is not None and not numbers(text, count):
            raise ValueError(f"{where}: <{tag}> {name}={text!r} is not {count} number{'s' if count > 1 else ''}")


def numbers(text: str, count: int) -> bool:
    """`text` is `count` numbers separated by white space."""
    parts = text.split()
    try:
        [float(part) for part in parts]
    except ValueError:
        return False
    return len(parts) == count


def urdfdom_reason(printed: list[str]) -> str | None:
    """Why urdfdom (Pinocchio's URDF parser) refused a file, from its captured output: it prints the reason, and its
    exception says only that it refuses (None: it printed none)."""
    reasons = [line.removeprefix("Error:").strip() for line in printed if line.startswith("Error:")]
    return reasons[0] if reasons else None


@contextlib.contextmanager
def refused_by(parser: str, urdf: str) -> Iterator[None]:
    """What `parser` raises reading the scenario's `urdf`, as a ValueError of one line (`robot.urdf: <file>: <parser>
    cannot read it: <why>`): the checks above cover what a URDF commonly gets wrong, this the rest."""
    try:
        yield
    except Exception as err:  # noqa: BLE001 - a parser's complaint about the file, whatever its class
        why = " ".join(str(err).split())
        raise ValueError(f"robot.urdf: {Path(urdf).name}: {parser} cannot read it: {why}") from None
