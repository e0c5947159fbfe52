"""Task-space references for both hands: t -> (position, rotation) per hand."""

from __future__ import annotations

import numpy as np

from harmony_cli.scenario import HoldReference, SCurveReference


def _quintic(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smoothstep 10t^3 - 15t^4 + 6t^5 on [0, 1] (clamped) and its derivative: starts and ends at rest."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10 - 15 * tau + 6 * tau**2), 30 * tau**2 * (1 - tau) ** 2


def rot_z(angle: np.ndarray) -> np.ndarray:
    """Rotations about z, shape angle.shape + (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.zeros(angle.shape + (3, 3))
    rot[..., 0, 0], rot[..., 0, 1], rot[..., 1, 0], rot[..., 1, 1], rot[..., 2, 2] = c, -s, s, c, 1.0
    return rot


class HandReference:
    """Rigidly moves the initial hand poses along a planar path c(t) with heading psi(t) about their midpoint."""

    def __init__(self, spec: SCurveReference | HoldReference, initial_poses: list[tuple[np.ndarray, np.ndarray]]):
        self.spec = spec
        self.p0 = np.array([p.ravel() for p, _ in initial_poses])  # (hands, 3)
        self.r0 = np.array([r for _, r in initial_poses])  # (hands, 3, 3)
        self.centre0 = self.p0.mean(axis=0)

    def path(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Midpoint displacement (n, 2) and heading (n,) at times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if isinstance(self.spec, HoldReference):
            return np.zeros((t.size, 2)), np.zeros(t.size)
        s = self.spec
        sigma, _ = _quintic((t - s.start) / s.duration)
        x = s.length * sigma
        phase = 2 * np.pi * sigma
        y = s.lateral * (sigma - np.sin(phase) / (2 * np.pi))  # lane change: dy/dx = 0 at both ends
        heading = np.arctan2(s.lateral * (1 - np.cos(phase)), s.length)
        return np.stack([x, y], axis=1), heading

    def poses(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Hand positions (n, hands, 3) and rotations (n, hands, 3, 3) at times t."""
        shift, heading = self.path(t)
        rz = rot_z(heading)  # (n, 3, 3)
        arm = self.p0 - self.centre0  # (hands, 3)
        pos = self.centre0 + np.einsum("nij,hj->nhi", rz, arm)
        pos[..., :2] += shift[:, None, :]
        rot = np.einsum("nij,hjk->nhik", rz, self.r0)
        return pos, rot
