"""Rotations about the vertical axis and rotation errors."""

from __future__ import annotations

import numpy as np


def rot_z(angle: np.ndarray) -> np.ndarray:
    """Rotations about z, shape angle.shape + (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.zeros(angle.shape + (3, 3))
    rot[..., 0, 0], rot[..., 0, 1], rot[..., 1, 0], rot[..., 1, 1], rot[..., 2, 2] = c, -s, s, c, 1.0
    return rot


def rotation_error_deg(r: np.ndarray, r_ref: np.ndarray) -> float:
    """Angle of r_ref^T r [deg]."""
    cos = (np.trace(r_ref.T @ r) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def heading_of(rotations: np.ndarray, home_rotations: np.ndarray) -> float:
    """Common heading of the hands: mean yaw of R_h R_h(home)^T."""
    relative = np.einsum("hij,hkj->hik", rotations, home_rotations)
    return float(np.arctan2(relative[:, 1, 0].sum(), relative[:, 0, 0].sum()))


def off_square_deg(box_x: np.ndarray, line: np.ndarray) -> float:
    """[deg] in plan view, how far a box (its x axis `box_x` (3,) in the world) is turned from lying square across
    the direction `line` (3,): the angle between the line and the nearest of the box's side axes, in [0, 45]. With
    the pads' normal as the line, 0: the pads lie flat on two opposite faces; above it they hold it on its edges."""
    angle = np.degrees(np.arctan2(box_x[1], box_x[0]) - np.arctan2(line[1], line[0])) % 90.0
    return float(min(angle, 90.0 - angle))


def pad_axis(normals: np.ndarray) -> np.ndarray:
    """The axis (3,) of two pads facing each other from their normals (2, 3): their difference when they point at
    each other (or apart), their sum when a robot's frames give both the same way."""
    return normals[1] - normals[0] if float(normals[0] @ normals[1]) < 0 else normals[1] + normals[0]


def grip_shear(positions: np.ndarray, axis: np.ndarray) -> float:
    """[m] in plan view, how far one hand (positions (2, 3)) is ahead of the other across the pads' `axis`: 0 when
    the line between them is the axis; otherwise their squeeze is a couple that turns what they hold."""
    d, u = (positions[1] - positions[0])[:2], axis[:2] / max(float(np.hypot(*axis[:2])), 1e-12)
    return float(abs(d[0] * u[1] - d[1] * u[0]))


def quaternion_matrices(quaternions) -> np.ndarray:
    """(n, 3, 3) rotation matrices of quaternions (x, y, z, w), by Bullet's formula (btMatrix3x3::setRotation) in
    the same operations: bit for bit what PyBullet's getMatrixFromQuaternion gives, without PyBullet."""
    x, y, z, w = np.asarray(quaternions, dtype=float).reshape(-1, 4).T
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    rows = (1.0 - (yy + zz), xy - wz, xz + wy, xy + wz, 1.0 - (xx + zz), yz - wx, xz - wy, yz + wx, 1.0 - (xx + yy))
    return np.stack(rows, axis=-1).reshape(-1, 3, 3)
