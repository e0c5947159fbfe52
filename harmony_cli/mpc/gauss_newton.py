"""harmony's own solver modes: Gauss-Newton SQP on the knot structure with one sparse or dense QP per iteration,
and real-time iteration (one QP per control step)."""

from __future__ import annotations

import time
from functools import cached_property
from typing import Any

import casadi as cs
import numpy as np
import scipy.sparse as sp

from harmony_cli.mpc.codegen import Buffered
from harmony_cli.mpc.far_rows import FarBound
from harmony_cli.mpc.knot_constraints import shared_constraints
from harmony_cli.mpc.knot_derivatives import shared_derivatives
from harmony_cli.mpc.knot_rows import KnotRows
from harmony_cli.mpc.problem import Problem, SolveContext, SolveResult
from harmony_cli.mpc.reduction import Reduction
from harmony_cli.mpc.row_screen import REACH_SAFETY, DenseRows, ScreenedQP

SCREENED = ("daqp", "qpoases")  # dense active-set solvers: their cost grows with the rows they are given


class GaussNewtonSolver:
    """Gauss-Newton SQP with structured Hessians and a QP per iteration over the free variables (see Reduction);
    nonlinear constraint rows are linearised at each iterate. `max_iter=1` is real-time iteration."""

    def __init__(
        self, problem: Problem, qp: str, max_iter: int, tol: float, name: str = "gauss_newton", damping: float = 1e-6
    ):
        self.problem, self.max_iter, self.tol, self.name = problem, max_iter, tol, name
        # the clearance rows' C (the largest) starts compiling first; `path` and the first solve wait for gcc
        self.constraints = shared_constraints(problem) if problem.constraint is not None else None
        self.model = shared_derivatives(problem)
        self.qp_name = qp
        self.options: dict[str, Any] = {"error_on_fail": False}
        if qp == "qpoases":
            self.options |= {"printLevel": "none"}
        elif qp == "osqp":
            self.options |= {"osqp": {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "max_iter": 4000}}
        self._qps: dict[bytes, tuple] = {}
        self.regularisation = damping
        # this solver's own bound on the far rows (the constraints' maps are shared by every solver of the problem)
        self.far = FarBound(problem.far) if self.constraints is not None and problem.far is not None else None

    @cached_property
    def path(self) -> str:
        rows = "" if self.constraints is None else f", clearance rows linearised ({self.constraints.code_path})"
        return f"{self.name}: {self.qp_name} QP, derivatives from {self.model.code_path} per-knot maps{rows}"

    @cached_property
    def context(self) -> SolveContext:
        return SolveContext(self.problem, self.path, None if self.constraints is None else self._margins)

    def _margins(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The constraint rows at x for its violation, the far rows only where this solver's bound cannot show
        them clear (they are then not violated)."""
        assert self.constraints is not None
        return self.constraints.margins(x, p, self.far)

    def _qp(self, free: np.ndarray):
        """(QP, Reduction, the kept Hessian nonzeros (as KnotDerivatives.taking gives them), their diagonal, how the
        constraint rows get their values), built once per pattern. The QP's rows are the reduced linear rows, then
        the linearised constraints."""
        if free.tobytes() not in self._qps:
            r, rows, cols, index = Reduction(self.problem.A, free), self.model.rows, self.model.cols, np.cumsum(free)
            kept = np.flatnonzero(free[rows] & free[cols])  # still in CCS order
            h = cs.Sparsity.triplet(r.n, r.n, (index[rows[kept]] - 1).tolist(), (index[cols[kept]] - 1).tolist())
            diagonal = np.flatnonzero(rows[kept] == cols[kept])
            taken = self.model.taking(kept)
            if self.qp_name in SCREENED:  # dense rows, only those that can matter (mpc/row_screen.py)
                m = r.A_free.shape[0] + (0 if self.constraints is None else self.constraints.n_rows)
                screened = ScreenedQP(self.qp_name, self.options, h, m)
                A = r.A_free.toarray()
                self._qps[free.tobytes()] = screened, r, taken, diagonal, (A, np.abs(A))
            else:
                solver, from_c = self._sparse_qp(free, r, h)
                self._qps[free.tobytes()] = solver, r, taken, diagonal, from_c
        return self._qps[free.tobytes()]

    def _sparse_qp(self, free: np.ndarray, r: Reduction, h: cs.Sparsity):
        """A sparse QP over every row: the matrix's nonzeros in CCS order come from A (code < 0) or from C[:, free]
        (code > 0); returns (solver, the constraint entries' (slots, sources))."""
        codes = r.A_free.copy()
        codes.data = -1.0 - np.arange(codes.nnz)
        if self.constraints is not None:
            pattern = self.constraints.pattern[:, free]
            dense = np.where(pattern, 1.0 + np.arange(pattern.size).reshape(pattern.shape), 0.0)
            codes = sp.vstack([codes, sp.csc_matrix(dense)]).tocsc()
        codes.sort_indices()
        a = cs.Sparsity(*codes.shape, codes.indptr.tolist(), codes.indices.tolist())
        solver = Buffered(cs.conic("gn_qp", self.qp_name, {"h": h, "a": a}, self.options))
        from_a = codes.data < 0
        solver.args["a"][from_a] = r.A_free.data[(-codes.data[from_a] - 1).astype(int)]
        from_c = np.flatnonzero(~from_a), (codes.data[~from_a] - 1).astype(int)  # slot, entry of C[:, free]
        if self.constraints is not None:  # each entry's source in the per-knot Jacobians
            n_free = int(free.sum())
            source = self.constraints.entries(from_c[1] // n_free, np.flatnonzero(free)[from_c[1] % n_free])
            from_c = from_c[0], source
        return solver, from_c

    def prepare(self, lbx: np.ndarray, ubx: np.ndarray) -> None:
        """The QP of this pattern (a dense one's solver for every row count), and the compiled maps loaded."""
        qp = self._qp(lbx < ubx)[0]
        if isinstance(qp, ScreenedQP):
            qp.prepare()
        self.model.knots  # noqa: B018 - loads the compiled code (waits for gcc on a cold cache)
        if self.constraints is not None:
            self.constraints.map  # noqa: B018
            if self.far is not None:
                self.constraints.far_map  # noqa: B018

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        built = time.perf_counter()
        free = lbx < ubx
        qp, r, taken, diagonal, rows_from = self._qp(free)
        start = time.perf_counter()
        build_time = start - built  # microseconds unless this pattern is new
        x = np.clip(x0, lbx, ubx)  # the fixed variables are exact from here on
        status, success, qp_rows, qp_solves = "max_iter", False, 0, 0
        for it in range(1, self.max_iter + 1):  # noqa: B007 - the count is returned
            _, g, h = self.model.evaluate(x, p, taken)
            h[diagonal] += self.regularisation
            bounds = h, g[free], lbx[free] - x[free], ubx[free] - x[free]
            for relaxed in (False, True) if self.constraints is not None else (False,):
                if isinstance(qp, ScreenedQP):
                    dz, failure, rows, solves = self._screened_step(qp, rows_from, r, x, p, free, bounds, relaxed)
                else:
                    dz, failure, rows, solves = self._sparse_step(qp, rows_from, r, x, p, bounds, relaxed)
                qp_rows, qp_solves = qp_rows + rows, qp_solves + solves
                if dz is not None:
                    break
            if dz is None:
                status, success = f"qp_failed: {failure}", False
                break
            x[free] += dz
            if self.max_iter == 1:
                status, success = "rti_step (clearance relaxed)" if relaxed else "rti_step", True
            elif np.max(np.abs(dz)) < self.tol:
                status, success = "converged", True
                break
        return SolveResult(
            x,
            success,
            status,
            it,
            time.perf_counter() - start,
            build_time,
            self.context,
            p.copy(),
            lbx.copy(),
            ubx.copy(),
            qp_rows,
            qp_solves,
        )

    def _screened_step(self, qp: ScreenedQP, A: tuple, r: Reduction, x, p, free, bounds, relaxed: bool = False):
        """(step or None, the solver's failure status, rows solved, QPs solved) of a dense QP over the rows that
        can matter (mpc/row_screen.py): the same optimum as over every row. `relaxed`: see _needs."""
        h, g, lbx, ubx = bounds
        if self.constraints is None:
            out = qp.solve(h, g, lbx, ubx, DenseRows(*A), *r.rows(self.problem.lb, self.problem.ub, x))
            return (out.z if out.success else None), out.status, out.rows, out.solves
        # the far rows only where a step like the last (REACH_SAFETY times it) could bring them to their bounds,
        # and again where the step taken could: the same optimum as with them (mpc/far_rows.py)
        step = self._knot_steps(REACH_SAFETY * qp.reach, free)
        solves, (linear_lo, linear_hi) = 0, r.rows(self.problem.lb, self.problem.ub, x)
        for evaluated_now in (False, True):
            value, lower, J, evaluated = self.constraints.jacobians(x, p, self.far, None if evaluated_now else step)
            rows = KnotRows(A[0], A[1], J, self.constraints.B[1:], free)
            lba = np.concatenate([linear_lo, _needs(lower - value, relaxed)])
            uba = np.r_[linear_hi, np.full(value.size, np.inf)]
            out = qp.solve(h, g, lbx, ubx, rows, lba, uba)
            solves += out.solves
            if evaluated or not out.success or self._far_clear(x, p, self._knot_steps(out.z, free)):
                break
        return (out.z if out.success else None), out.status, out.rows, solves

    def _far_clear(self, x: np.ndarray, p: np.ndarray, step: np.ndarray) -> bool:
        """Whether the far rows left out cannot bind after a step changing the knots' joints by at most `step`."""
        assert self.constraints is not None and self.far is not None
        return self.far.clear(*self.constraints.knots(x, p), step)

    def _knot_steps(self, z: np.ndarray, free: np.ndarray) -> np.ndarray:
        """|joint change| at each knot (n_dof x K) bounded from a step's sizes over the free variables."""
        assert self.constraints is not None
        full = np.zeros(free.size)
        full[free] = np.abs(z)
        n_dof, B = self.constraints.n_dof, self.constraints.B
        return full[: n_dof * B.shape[1]].reshape((n_dof, B.shape[1]), order="F") @ np.abs(B).T

    def _sparse_step(self, qp: Buffered, from_c, r: Reduction, x, p, bounds, relaxed: bool = False):
        """(step or None, the solver's failure status, rows, 1) of a sparse QP over every row."""
        c_slots, c_source = from_c
        lba, uba = r.rows(self.problem.lb, self.problem.ub, x)
        if self.constraints is not None:  # h + C dz >= lower
            value, lower, qp.args["a"][c_slots] = self.constraints.evaluate_entries(x, p, c_source)
            lba, uba = np.concatenate([lba, _needs(lower - value, relaxed)]), np.r_[uba, np.full(value.size, np.inf)]
        h, g, lbx, ubx = bounds
        out = qp(h=h, g=g, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        stats = qp.stats()
        if not stats["success"]:
            return None, stats.get("return_status", "?"), lba.size, 1
        return out["x"], "", lba.size, 1


def _needs(need: np.ndarray, relaxed: bool) -> np.ndarray:
    """What the linearised clearance rows ask of a step: `need` (C dz >= need; > 0 where a row is violated now).
    Relaxed (after the QP found no step meeting them all: the linearisations of rows violated at several knots
    can contradict each other), a violated row asks only not to get worse; dz = 0 then meets every row, so the
    MPC still moves the robot, on the rows' side of every tangent, instead of holding a stale plan."""
    return np.minimum(need, 0.0) if relaxed else need
