"""Task-space references for both hands: t -> (position, rotation) per hand."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.scalings import quintic
from harmony_cli.robot.observation import Observation
from harmony_cli.scenario.task import HoldReference
from harmony_cli.tasks.targets import HandTargets

if TYPE_CHECKING:
    from harmony_cli.scenario.task import Reference


class HandReference:
    """Rigidly moves the initial hand poses along a planar path c(t) with heading psi(t) about their midpoint."""

    def __init__(self, spec: Reference, initial_poses: list[tuple[np.ndarray, np.ndarray]]):
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
        sigma = quintic((t - s.start) / s.duration)
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


class TrajectoryReferences:
    """A fixed hand trajectory (Table 1) as the loop's reference source: it never waits (delay 0)."""

    delay = 0.0

    def __init__(self, reference: HandReference):
        self.reference = reference

    def plan(self, t: float, obs: Observation, knot_times: np.ndarray) -> HandTargets:
        positions, rotations = self.reference.poses(t + knot_times)
        return HandTargets(positions, rotations, positions[0])
