"""A dense QP solved over the inequality rows that can matter, verified against all of them.

min 1/2 z'Hz + g'z  s.t.  lbx <= z <= ubx,  lo <= G z <= hi

A dense active-set solver's cost grows with its rows (DAQP at n = 108: ~0.5 ms with 16 rows, ~2 ms with 375), and
in an MPC step most rows are far from their bounds (clearance to obstacles metres away, joint speeds well inside
their limits). `ScreenedQP` gives the solver the rows a step like the last one could reach, plus the rows that were
active last time; rows the solution violates are then added and the QP solved again. The result is the full QP's
optimum: it is optimal for a relaxation of the full QP (a subset of its rows) and feasible for all of them. The
screen only decides how fast that is found, never what is found."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import Buffered

SLOT_STEP = 16  # rows are padded to a multiple of this: one solver per size, few sizes (0 rows: none)
REACH_SAFETY = 2.0  # a row is kept when a step twice the size of the last one could reach its bound
FEASIBILITY = 1e-9  # a dropped row violated by more than this is added


class Rows(Protocol):
    """The rows G of a QP, as the screen uses them (a structured G need never be formed whole)."""

    def reach(self, step: np.ndarray) -> np.ndarray:
        """|G| @ step: how far a step of these sizes could move each row."""

    def times(self, z: np.ndarray) -> np.ndarray:
        """G @ z."""

    def take(self, rows: np.ndarray) -> np.ndarray:
        """G[rows] as a dense array."""


class DenseRows:
    """Rows given as a dense matrix."""

    def __init__(self, G: np.ndarray, magnitude: np.ndarray | None = None):
        self.G, self.magnitude = G, np.abs(G) if magnitude is None else magnitude  # |G|, if known already

    def reach(self, step: np.ndarray) -> np.ndarray:
        return self.magnitude @ step

    def times(self, z: np.ndarray) -> np.ndarray:
        return self.G @ z

    def take(self, rows: np.ndarray) -> np.ndarray:
        return self.G[rows]


@dataclass(frozen=True)
class ScreenedSolution:
    z: np.ndarray
    success: bool
    status: str  # the solver's return status when it failed
    rows: int  # rows in the last QP solved
    solves: int  # QPs solved (1 unless dropped rows had to be added)


class ScreenedQP:
    """One QP structure (Hessian sparsity `h`, n variables, m rows of G); `solve` may be called with new values
    every time. Solvers for each padded row count are built on first use (or all by `prepare`) and kept."""

    def __init__(self, qp: str, options: dict, h: cs.Sparsity, m: int):
        self.qp, self.options, self.h, self.n, self.m = qp, options, h, h.size1(), m
        self._solvers: dict[int, Buffered] = {}
        self.active = np.zeros(m, dtype=bool)  # rows active last time (none yet: the check adds what is needed)
        self.reach = np.zeros(self.n)  # |last step| per variable

    def prepare(self) -> None:
        """A solver for every padded row count built now (0.2-0.5 ms each): none is built mid-loop, where a
        jump in the references first needs more rows."""
        for rows in range(0, self.m + SLOT_STEP, SLOT_STEP):
            self._solver(self._slots(rows))

    def _slots(self, rows: int) -> int:
        """The padded row count of a QP over `rows` rows (none: no padding rows either)."""
        return min(-(-rows // SLOT_STEP) * SLOT_STEP, self.m)

    def _solver(self, slots: int) -> Buffered:
        if slots not in self._solvers:
            structure = {"h": self.h, "a": cs.Sparsity.dense(slots, self.n)}
            self._solvers[slots] = Buffered(cs.conic(f"screened_qp_{slots}", self.qp, structure, self.options))
        return self._solvers[slots]

    def solve(self, h, g, lbx, ubx, G: Rows, lo: np.ndarray, hi: np.ndarray) -> ScreenedSolution:
        change = REACH_SAFETY * G.reach(self.reach)
        keep = self.active | (-lo < change) | (hi < change)  # at z = 0 the rows are 0: slack -lo and hi
        solves = 0
        while True:
            rows = np.flatnonzero(keep)
            z, stats, lam = self._solve_rows(rows, h, g, lbx, ubx, G, lo, hi)
            solves += 1
            if not stats["success"]:
                return ScreenedSolution(z, False, str(stats.get("return_status", "?")), rows.size, solves)
            Gz = G.times(z)
            violated = ~keep & ((lo - Gz > FEASIBILITY) | (Gz - hi > FEASIBILITY))
            if not violated.any():
                break
            keep |= violated
        self.active[:] = False
        self.active[rows[lam != 0.0]] = True
        self.reach = np.abs(z)
        return ScreenedSolution(z, True, "", rows.size, solves)

    def _solve_rows(self, rows, h, g, lbx, ubx, G, lo, hi):
        """The QP with rows G[rows] and zero padding rows without bounds."""
        slots = self._slots(rows.size)
        solver = self._solver(slots)
        a = solver.args["a"].reshape(self.n, slots)  # column-major: a[:, i] is row i
        a[:, : rows.size] = G.take(rows).T
        a[:, rows.size :] = 0.0
        solver.args["lba"][:] = -np.inf
        solver.args["uba"][:] = np.inf
        solver.args["lba"][: rows.size], solver.args["uba"][: rows.size] = lo[rows], hi[rows]
        out = solver(h=h, g=g, lbx=lbx, ubx=ubx)
        return out["x"].copy(), solver.stats(), out["lam_a"][: rows.size].copy()
