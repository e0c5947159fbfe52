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
from harmony_cli.mpc.knot_derivatives import shared_constraints, shared_derivatives
from harmony_cli.mpc.problem import Problem, SolveContext, SolveResult
from harmony_cli.mpc.reduction import Reduction


class GaussNewtonSolver:
    """Gauss-Newton SQP with structured Hessians and a QP per iteration over the free variables (see Reduction);
    nonlinear constraint rows are linearised at each iterate. `max_iter=1` is real-time iteration."""

    def __init__(self, problem: Problem, qp: str, max_iter: int, tol: float, name: str = "gauss_newton"):
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
        self.regularisation = 1e-6

    @cached_property
    def path(self) -> str:
        rows = "" if self.constraints is None else f", clearance rows linearised ({self.constraints.code_path})"
        return f"{self.name}: {self.qp_name} QP, derivatives from {self.model.code_path} per-knot maps{rows}"

    @cached_property
    def context(self) -> SolveContext:
        return SolveContext(self.problem, self.path, None if self.constraints is None else self.constraints.margins)

    def _qp(self, free: np.ndarray):
        """(QP solver, Reduction, kept Hessian nonzeros, their diagonal, constraint Jacobian nonzeros), built once
        per pattern. The QP's rows are the reduced linear rows, then the linearised constraints (values each
        iteration): the matrix's nonzeros in CCS order come from A (code < 0) or from C[:, free] (code > 0)."""
        if free.tobytes() not in self._qps:
            r, rows, cols, index = Reduction(self.problem.A, free), self.model.rows, self.model.cols, np.cumsum(free)
            kept = np.flatnonzero(free[rows] & free[cols])  # still in CCS order
            h = cs.Sparsity.triplet(r.n, r.n, (index[rows[kept]] - 1).tolist(), (index[cols[kept]] - 1).tolist())
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
            self._qps[free.tobytes()] = solver, r, kept, np.flatnonzero(rows[kept] == cols[kept]), from_c
        return self._qps[free.tobytes()]

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        built = time.perf_counter()
        free = lbx < ubx
        qp, r, kept, diagonal, (c_slots, c_source) = self._qp(free)
        start = time.perf_counter()
        build_time = start - built  # microseconds unless this pattern is new
        x = np.clip(x0, lbx, ubx)  # the fixed variables are exact from here on
        status, success = "max_iter", False
        for it in range(1, self.max_iter + 1):  # noqa: B007 - the count is returned
            _, g, vals = self.model.evaluate(x, p)
            h = vals[kept]
            h[diagonal] += self.regularisation
            lba, uba = r.rows(self.problem.lb, self.problem.ub, x)
            if self.constraints is not None:  # h + C dz >= lower
                value, lower, qp.args["a"][c_slots] = self.constraints.evaluate_entries(x, p, c_source)
                lba, uba = np.concatenate([lba, lower - value]), np.concatenate([uba, np.full(value.size, np.inf)])
            out = qp(h=h, g=g[free], lba=lba, uba=uba, lbx=lbx[free] - x[free], ubx=ubx[free] - x[free])
            stats = qp.stats()
            if not stats["success"]:
                status, success = f"qp_failed: {stats.get('return_status', '?')}", False
                break
            x[free] += out["x"]
            if self.max_iter == 1:
                status, success = "rti_step", True
            elif np.max(np.abs(out["x"])) < self.tol:
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
        )
