"""Constraint rows left unevaluated while a Lipschitz bound shows that no step can bring them to their bounds.

The arms' clearance rows are the costliest part of a whole-body MPC step (a soft-min over every arm point per
body, with its Jacobian) and are far from their bounds most of the time. Each such row h(q, pose) is a signed
distance (1-Lipschitz in a point's position and in its body's position) of points whose speed per unit of joint
j's motion is at most lever_j in every configuration (robot/arm_points.py). So from its value h_0 at the knots'
joints q_0 and body poses c_0, at any q and c, and after a step dq (its linearisation's change is bounded alike)

    h(q, c) + J dq >= h_0 - sum_j lever_j (|q_j - q_0j| + |dq_j|) - |c - c_0|,

the body's yaw unchanged. When that is >= 0 at every knot (knot 0's too: then the rows' lower bound,
min(0, h(q_now)), is 0) the rows cannot bind: the QP without them has the optimum of the QP with them. The
solver evaluates them only when the bound no longer says so, checks the bound again with the step it took, and
evaluates them and solves again when that fails: what is found is the same, only faster."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FarRows:
    """The constraint's last rows: `levers` (the constraint's q) bounds |dh/dq_j| of each of them in every
    configuration; `poses` (rows, 4) where each row's body's centre (3) and yaw sit in a knot's parameters."""

    levers: np.ndarray
    poses: np.ndarray


class FarBound:
    """The rows' values at the last point they were evaluated at, and whether they can bind at another."""

    def __init__(self, far: FarRows):
        self.far = far
        self._joints = np.flatnonzero(far.levers)  # the joints that move an arm point
        self._levers = far.levers[self._joints]
        self._q: np.ndarray | None = None  # (joints, K) where they were evaluated
        self._h = np.zeros(0)  # (K, rows) their values there
        self._lowest = np.zeros(0)  # (K,) the smallest of them per knot
        self._poses = np.zeros(0)  # (rows, 4, K) their bodies' centres and yaws there

    def store(self, q: np.ndarray, ref: np.ndarray, h: np.ndarray) -> None:
        """The rows' values h (K, rows) at the knots' joints q (n_q, K) and parameters ref (m, K)."""
        self._q, self._h, self._lowest = q[self._joints], h.copy(), h.min(axis=1)
        self._poses = ref[self.far.poses]

    def clear(self, q: np.ndarray, ref: np.ndarray, step: np.ndarray) -> bool:
        """Whether every row stays >= 0 at the knots' joints q (n_q, K) and parameters ref (m, K) after any step
        whose joints change by at most `step` (n_q, K) at each knot."""
        if self._q is None:
            return False
        drift = self._levers @ (np.abs(q[self._joints] - self._q) + step[self._joints])  # (K,)
        poses = ref[self.far.poses]
        if np.array_equal(poses, self._poses):  # the bodies stood still
            return bool(np.all(self._lowest >= drift))
        if np.any(poses[:, 3] != self._poses[:, 3]):  # a body turned: the bound does not cover it
            return False
        moved = np.linalg.norm(poses[:, :3] - self._poses[:, :3], axis=1)  # (rows, K)
        return bool(np.all(self._h.T - drift[None, :] - moved >= 0.0))
