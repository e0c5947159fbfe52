"""Fixed variables (lbx == ubx: the measured state, pinned joints) eliminated from a problem's linear rows."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class Reduction:
    """The problem without the variables fixed by lbx == ubx (initial state, pinned joints) and without the rows
    that then have no free variable: smaller, and the equality rows left stay linearly independent."""

    def __init__(self, A: np.ndarray, free: np.ndarray):
        self.idx, self.n = np.flatnonzero(free), int(free.sum())
        self.a = np.flatnonzero(np.any(A[:, free] != 0, axis=1))
        self.A, self.A_free = sp.csr_matrix(A[self.a]), sp.csc_matrix(A[self.a][:, free])

    def rows(self, lb: np.ndarray, ub: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on A_free z with A x's part (x: fixed values, anything else where z will be added) moved over."""
        offset = self.A @ x
        return lb[self.a] - offset, ub[self.a] - offset
