"""URDF <origin> elements as 4x4 transforms, and a joint's motion at a given value, for rewriting a URDF's tree."""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation as RotationType

ROTATING = ("revolute", "continuous")


def _rotation() -> type[RotationType]:
    """SciPy's Rotation, imported when a URDF is rewritten (scipy.spatial takes ~0.4 s to import; a run whose
    prepared URDF is cached never needs it)."""
    from scipy.spatial.transform import Rotation

    return Rotation


def _floats(text: str | None, default: str = "0 0 0") -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def origin_matrix(element: ET.Element) -> np.ndarray:
    """The transform of `element`'s <origin> child (identity without one); URDF rpy is fixed-axis x, y, z."""
    origin = element.find("origin")
    transform = np.eye(4)
    if origin is not None:
        transform[:3, :3] = _rotation().from_euler("xyz", _floats(origin.get("rpy"))).as_matrix()
        transform[:3, 3] = _floats(origin.get("xyz"))
    return transform


def pose_matrix(xyz, rpy) -> np.ndarray:
    transform = np.eye(4)
    transform[:3, :3] = _rotation().from_euler("xyz", rpy).as_matrix()
    transform[:3, 3] = xyz
    return transform


def set_origin(element: ET.Element, transform: np.ndarray) -> None:
    """Replace `element`'s <origin> with `transform` (kept first among its children, where URDFs put it)."""
    old = element.find("origin")
    if old is not None:
        element.remove(old)
    with warnings.catch_warnings():  # at pitch +-90 deg scipy picks yaw = 0: still the same rotation
        warnings.simplefilter("ignore", UserWarning)
        rpy = _rotation().from_matrix(transform[:3, :3]).as_euler("xyz")
    origin = ET.Element("origin", xyz=_text(transform[:3, 3]), rpy=_text(rpy))
    element.insert(0, origin)


def _text(values) -> str:
    return " ".join(f"{float(v):.12g}" for v in np.where(np.abs(values) < 1e-15, 0.0, values))


def joint_motion(joint: ET.Element, value: float) -> np.ndarray:
    """The transform a movable joint adds after its origin at `value` [rad | m] about / along its axis."""
    element = joint.find("axis")
    axis = _floats(None if element is None else element.get("xyz"), "1 0 0")
    axis = axis / np.linalg.norm(axis)
    motion = np.eye(4)
    if joint.get("type") in ROTATING:
        motion[:3, :3] = _rotation().from_rotvec(axis * value).as_matrix()
    elif joint.get("type") == "prismatic":
        motion[:3, 3] = axis * value
    else:
        raise ValueError(f"joint {joint.get('name')!r}: cannot move a {joint.get('type')} joint")
    return motion
