"""The whole-body MPC's QP rows on the knot structure, for the screened QP (row_screen.Rows): the reduced linear
rows, then the clearance rows linearised at the knots, C = J_k (x) b_k, never formed whole.

Row (k - 1) * m + j of the clearance block is J_k[j, i] B[k, a] on position variable (joint i, control point a),
index a * n_dof + i; |C| v and C z are per-knot products J_k (V b_k) of V, v's positions as n_dof x n_pos."""

from __future__ import annotations

import numpy as np


class KnotRows:
    """[A; C][:, free] of one QP step: A dense (the reduced linear rows, already over the free variables), C from
    the per-knot Jacobians J (K - 1, m, n_dof) at knots >= 1 and their bases B (K - 1, n_pos)."""

    def __init__(self, A: np.ndarray, abs_A: np.ndarray, J: np.ndarray, B: np.ndarray, free: np.ndarray):
        self.A, self.abs_A, self.J, self.B, self.free = A, abs_A, J, B, free
        self.n_dof, self.n_pos = J.shape[2], B.shape[1]
        self._full = np.zeros(free.size)

    def _positions(self, v_free: np.ndarray) -> np.ndarray:
        """n_dof x n_pos: the position variables of a vector over the free variables (fixed ones 0)."""
        self._full[self.free] = v_free
        return self._full[: self.n_dof * self.n_pos].reshape((self.n_dof, self.n_pos), order="F")

    def reach(self, step: np.ndarray) -> np.ndarray:
        at_knots = self._positions(step) @ np.abs(self.B).T  # n_dof x (K - 1)
        return np.concatenate([self.abs_A @ step, np.einsum("kji,ik->kj", np.abs(self.J), at_knots).ravel()])

    def times(self, z: np.ndarray) -> np.ndarray:
        at_knots = self._positions(z) @ self.B.T
        return np.concatenate([self.A @ z, np.einsum("kji,ik->kj", self.J, at_knots).ravel()])

    def take(self, rows: np.ndarray) -> np.ndarray:
        linear = rows[rows < self.A.shape[0]]
        knot, j = np.divmod(rows[rows >= self.A.shape[0]] - self.A.shape[0], self.J.shape[1])
        C = np.zeros((knot.size, self.free.size))
        products = self.J[knot, j][:, None, :] * self.B[knot][:, :, None]  # (row, a, i): the entries of C
        C[:, : self.n_dof * self.n_pos] = products.reshape(knot.size, self.n_dof * self.n_pos)
        return np.vstack([self.A[linear], C[:, self.free]])
