"""`robot.mount: auto`: the mount that rests a robot on the ground when its URDF puts part of it below the floor
(a root at the pelvis, the torso or a pedestal's top), from the lowest point of its collision model at home.

The lowest point is exact, not a bound: a mesh's is one of its vertices (taken as Pinocchio loads them, the URDF's
scale applied), a primitive's (box, sphere, cylinder, capsule) is coal's closed-form signed distance to the
ground's half-space, which holds below the ground as above it. Axis-aligned bounding boxes (PyBullet's) would only
bound it: a turned mesh's or cylinder's is the box round its own turned box, lower than the shape; and the robot
package does not load the simulator. PyBullet keeps a collision margin of a millimetre round meshes and cylinders,
so a robot auto raises touches the ground there as a resting one does. Cached on disk by the URDF's content and
the home pose (Pinocchio takes a moment to import and to load the meshes: a warm run needs neither)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import numpy as np

from harmony_cli.cache import cached_json
from harmony_cli.capture import captured_output
from harmony_cli.robot.urdf_form import urdfdom_reason

# A model at most this far below the ground already rests on it (the mount auto puts in rests it within this),
# and one clear of the ground stays where its URDF places it: its root is then the floor's frame (a mobile
# base's footprint), whose collision model may leave out the wheels.
RESTING_M = 1e-3


class UnreadableUrdf(ValueError):
    """Pinocchio's URDF parser (urdfdom) refuses the file itself; the message is the reason it printed."""


@dataclass(frozen=True)
class Lowest:
    """The collision model's lowest point at home, with its root link at the origin."""

    z: float  # [m]; +inf for a model without collision shapes
    link: str  # the link it belongs to


def resting_mount(robot: ET.Element, home: dict[str, float]) -> tuple[tuple[list[float], list[float]] | None, Lowest]:
    """The mount (xyz [m], rpy [deg]) that lifts the model's lowest point at `home` [rad | m] onto the ground, or
    None when no point is deeper than RESTING_M below it; and that lowest point. `robot`: the URDF's tree with its
    mesh filenames absolute and without harmony's virtual base."""
    lowest = lowest_point(robot, home)
    if lowest.z >= -RESTING_M:
        return None, lowest
    return ([0.0, 0.0, -lowest.z], [0.0, 0.0, 0.0]), lowest


def lowest_point(robot: ET.Element, home: dict[str, float]) -> Lowest:
    """The lowest point of the collision model with the joints `home` names at those values and every other at 0.
    UnreadableUrdf when the parser refuses the file; ValueError when its collision model cannot be read (a mesh
    Pinocchio cannot load)."""
    text = ET.tostring(robot, encoding="unicode")
    key = text.encode() + repr(sorted(home.items())).encode()
    value = cached_json("ground", key, lambda: _pinocchio_lowest(text, home))
    return Lowest(np.inf if value["z"] is None else value["z"], value["link"])


def _pinocchio_lowest(text: str, home: dict[str, float]) -> dict:
    import pinocchio as pin  # only when the cache does not have the answer

    with captured_output() as printed:
        try:
            model = pin.buildModelFromXML(text)
        except (ValueError, RuntimeError):
            model = None
    if model is None:
        raise UnreadableUrdf(f"Pinocchio (urdfdom) cannot read it: {urdfdom_reason(printed) or 'not a URDF model'}")
    try:
        with captured_output():
            geometry = pin.buildGeomFromUrdfString(model, text, pin.COLLISION)
    except (ValueError, RuntimeError) as err:  # coal's messages open with where it raised them; why: 'message:'
        lines = [line.strip() for line in str(err).splitlines() if line.strip()] or [type(err).__name__]
        why = next((line.removeprefix("message: ") for line in lines if line.startswith("message:")), lines[0])
        raise ValueError(f"robot.mount: auto cannot read the collision model ({why}); give robot.mount") from None
    q = pin.neutral(model)
    for joint, value in home.items():
        if model.existJointName(joint):
            q[model.joints[model.getJointId(joint)].idx_q] = value
    placements = geometry.createData()
    pin.updateGeometryPlacements(model, model.createData(), geometry, placements, q)
    lowest: dict = {"z": None, "link": ""}
    for shape, placement in zip(geometry.geometryObjects, placements.oMg):
        z = _lowest_z(shape.geometry, placement.rotation, placement.translation)
        if lowest["z"] is None or z < lowest["z"]:
            lowest = {"z": z, "link": model.frames[shape.parentFrame].name}
    return lowest


def _lowest_z(shape: Any, rotation: np.ndarray, translation: np.ndarray) -> float:
    """The lowest height of one collision shape placed at (rotation, translation)."""
    import coal  # Pinocchio's collision library, loaded with it

    if isinstance(shape, coal.BVHModelBase):  # a mesh: its lowest vertex
        return float((np.asarray(shape.vertices()) @ rotation[2]).min() + translation[2])
    ground = coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
    placed = coal.Transform3s(rotation, translation)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    return float(coal.distance(shape, placed, ground, coal.Transform3s(), request, result))
