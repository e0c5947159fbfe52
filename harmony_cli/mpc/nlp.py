"""harmony's CasADi layer: solve a built MPC problem with real equality rows, lbx/ubx bounds and warm starts.

OpTaS builds the problem (variables, parameters, named cost terms); solving through its own wrapper costs
3-5x (every equality becomes two rows, every bound a row, no dual warm start), so we call CasADi directly.
Speed: derivatives come from the knot structure (per-knot C code), fixed variables are eliminated, and
arrays cross into CasADi without copies.
"""

from __future__ import annotations

import time
from typing import Any

import casadi as cs
import numpy as np
import scipy.sparse as sp

from harmony_cli.mpc.codegen import Buffered
from harmony_cli.mpc.knot_constraints import shared_constraints
from harmony_cli.mpc.knot_derivatives import shared_derivatives
from harmony_cli.mpc.native_oracle import native_oracle
from harmony_cli.mpc.oracles import ConstraintOracle, Oracle
from harmony_cli.mpc.problem import Problem, SolveContext, SolveResult
from harmony_cli.mpc.reduction import Reduction
from harmony_cli.mpc.registry import SolverUnavailable, available_nlp_plugins, unavailable_message


class NlpSolver:
    """Any CasADi nlpsol plugin (IPOPT by default) on the reduced problem, primal + dual warm-started.

    f, gradient and Hessian come from the compiled knot structure (hessian="exact": the exact Hessian,
    "gauss_newton": the cost is a sum of squares and the constraints linear, so the KKT point is the same).
    """

    def __init__(self, problem: Problem, plugin: str, options: dict, hessian: str = "gauss_newton"):
        if plugin not in available_nlp_plugins():
            raise SolverUnavailable(unavailable_message(plugin))
        defaults: dict[str, Any] = {"print_time": False, "record_time": True, "calc_lam_p": False}
        if plugin == "ipopt":  # warm-started: a small initial barrier takes 3 iterations, not 5-12, to the optimum;
            # MUMPS's scaling (MC64) costs ~2 ms per solve and our KKT systems are well scaled (make bench)
            defaults |= {
                "ipopt.print_level": 0,
                "ipopt.sb": "yes",
                "ipopt.warm_start_init_point": "yes",
                "ipopt.mu_init": 1e-6,
                "ipopt.warm_start_bound_push": 1e-6,
                "ipopt.warm_start_mult_bound_push": 1e-6,
                "ipopt.mumps_permuting_scaling": 0,
                "ipopt.mumps_scaling": 0,
            }
        elif plugin in ("sqpmethod", "feasiblesqpmethod"):
            defaults |= {
                "print_header": False,
                "print_iteration": False,
                "print_status": False,
                "qpsol": "qrqp",
                "qpsol_options": {"print_iter": False, "print_header": False},
            }
        self.problem, self.plugin, self.options = problem, plugin, defaults | options
        # the clearance rows' C compiles in the background while the cost's does (their curvature: IPOPT's
        # Lagrangian Hessian)
        self.constraints = shared_constraints(problem, curvature=True) if problem.constraint is not None else None
        exact = hessian == "exact"
        model = shared_derivatives(problem, exact, compile_now=False)  # the native oracle has its own maps
        self.native = native_oracle(model, problem.p.numel())
        if self.native is None:  # no C compiler: the same derivatives through Python callbacks (~3 ms per solve)
            self.oracle = [Oracle(model, kind, problem.p.numel()) for kind in ("f", "grad", "hess")]
            self.oracle[0].grad = self.oracle[1]
        self.n_rows = 0 if self.constraints is None else self.constraints.n_rows
        if self.constraints is not None:
            self.constraints.curvature_map  # noqa: B018 - built now (waits for gcc), not in the first solve
            self.constraint_oracle = [
                ConstraintOracle(self.constraints, model, kind, problem.p.numel()) for kind in ("jac", "hess")
            ]
        cost = (
            "native C oracle (compiled C per-knot maps)"
            if self.native is not None
            else f"Python callbacks ({model.code_path} per-knot maps; no gcc for the native oracle)"
        )
        rows = (
            ""
            if self.constraints is None
            else f", clearance rows through Python callbacks ({self.constraints.code_path} per-knot maps)"
        )
        self.path = f"{plugin}: cost through the {cost}{rows}"
        self.context = SolveContext(problem, self.path, None if self.constraints is None else self.constraints.margins)
        self.lam_x, self.lam_g = np.zeros(problem.n_vars), np.zeros(problem.A.shape[0] + self.n_rows)
        self._solvers: dict[bytes, tuple] = {}
        self._solver(np.ones(problem.n_vars, dtype=bool))  # checks the options now, not at the first solve

    def _solver(self, free: np.ndarray):
        """nlpsol over z = x[free] with parameters [p; x[~free]], built once per pattern (MX wrappers: cheap)."""
        if free.tobytes() not in self._solvers:
            r, n_p, n, idx = Reduction(self.problem.A, free), self.problem.p.numel(), free.size, np.flatnonzero(free)
            z, pe, lam_f = cs.MX.sym("z", r.n), cs.MX.sym("p", n_p + n - r.n), cs.MX.sym("lam_f")
            place = lambda i: cs.DM(sp.csc_matrix((np.ones(i.size), (i, np.arange(i.size))), (n, i.size)))
            x, p = cs.mtimes(place(idx), z) + cs.mtimes(place(np.flatnonzero(~free)), pe[n_p:]), pe[:n_p]
            A = cs.DM(r.A_free)
            if self.native is not None:  # one call node; CasADi asks each use for only the outputs it needs
                f, grad, hess = self.native(x, p)
                f_grad = f
            else:  # f_grad: f from the same callback as the gradient (no second call for f)
                f, (f_grad, grad), hess = self.oracle[0](x, p), self.oracle[1](x, p), self.oracle[2](x, p)
            g, grad, jac, lam_g = cs.mtimes(A, z), grad[idx], A, cs.MX.sym("lam_g", r.a.size + self.n_rows)
            hess_lag = lam_f * hess[idx, idx]
            if self.constraints is not None:  # clearance rows
                h, dh = self.constraint_oracle[0](x, p)
                g, jac = cs.vertcat(g, h), cs.vertcat(jac, dh[:, idx])
                hess_lag += self.constraint_oracle[1](x, p, lam_g[r.a.size :])[idx, idx]
            triu = cs.triu if self.plugin in ("ipopt", "bonmin", "knitro") else (lambda h: h)  # their convention
            derivatives = {  # whichever of these the plugin takes
                "grad_f": cs.Function("grad_f", [z, pe], [f_grad, grad]),
                "jac_g": cs.Function("jac_g", [z, pe], [g, jac]),
                "jac_fg": cs.Function("jac_fg", [z, pe], [f_grad, grad, g, jac]),
                "hess_lag": cs.Function("hess_lag", [z, pe, lam_f, lam_g], [triu(hess_lag)]),
            }
            options = self.options | {k: v for k, v in derivatives.items() if k in cs.nlpsol_options(self.plugin)}
            try:
                solver = Buffered(cs.nlpsol("mpc", self.plugin, {"x": z, "p": pe, "f": f, "g": g}, options))
            except RuntimeError as exc:
                raise SolverUnavailable(
                    f"solver.name: {self.plugin!r} failed to initialise: {str(exc).splitlines()[-1]}"
                ) from None
            self._solvers[free.tobytes()] = solver, r
        return self._solvers[free.tobytes()]

    def prepare(self, lbx: np.ndarray, ubx: np.ndarray) -> None:
        """Nothing is built per pattern: the NLP solver was built whole."""

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        built = time.perf_counter()
        free = lbx < ubx
        solver, r = self._solver(free)
        start = time.perf_counter()
        build_time = start - built  # microseconds unless this pattern is new
        x = np.where(free, 0.0, lbx)
        lbg, ubg = r.rows(self.problem.lb, self.problem.ub, x)
        rows = np.r_[r.a, self.problem.A.shape[0] + np.arange(self.n_rows)]
        if self.constraints is not None:
            lower = self.constraints.lower(np.where(free, x0, lbx), p)
            lbg, ubg = np.r_[lbg, lower], np.r_[ubg, np.full(self.n_rows, np.inf)]
        out = solver(
            x0=x0[free],
            lbx=lbx[free],
            ubx=ubx[free],
            lbg=lbg,
            ubg=ubg,
            p=np.r_[p, lbx[~free]],
            lam_x0=self.lam_x[free],
            lam_g0=self.lam_g[rows],
        )
        stats = solver.stats()
        x[free] = out["x"]
        if stats["success"]:
            self.lam_x[:], self.lam_g[:] = 0.0, 0.0
            self.lam_x[free], self.lam_g[rows] = out["lam_x"], out["lam_g"]
        return SolveResult(
            x,
            bool(stats["success"]),
            str(stats["return_status"]),
            int(stats.get("iter_count", -1)),
            time.perf_counter() - start,
            build_time,
            self.context,
            p.copy(),
            lbx.copy(),
            ubx.copy(),
        )


class SymbolicNlpSolver:
    """For plugins that differentiate the problem themselves (e.g. blocksqp): CasADi's AD on the full SX problem,
    fixed variables as lbx == ubx. Slower than NlpSolver; used only when a plugin rejects its structured oracles."""

    def __init__(self, problem: Problem, plugin: str, options: dict, reason: str = ""):
        self.constraints = shared_constraints(problem) if problem.constraint is not None else None
        g = cs.mtimes(cs.DM(problem.A), problem.x)
        if self.constraints is not None and problem.constraint_at_knots is not None:
            (K, npos), nd = problem.position_basis.shape, self.constraints.n_dof
            q = cs.mtimes(cs.reshape(problem.x[: nd * npos], nd, npos), cs.DM(problem.position_basis.T))
            h = problem.constraint_at_knots(q, cs.reshape(problem.p, problem.ref_shape[0], K))
            g = cs.vertcat(g, cs.vec(h[:, 1:]))
        nlp = {"x": problem.x, "p": problem.p, "f": sum(problem.terms.values()), "g": g}
        try:
            self.solver = cs.nlpsol("mpc", plugin, nlp, {"print_time": False} | options)
        except RuntimeError as exc:
            raise SolverUnavailable(
                f"solver.name: {plugin!r} failed to initialise: {str(exc).splitlines()[-1]}"
            ) from None
        self.problem = problem
        self.path = f"{plugin}: CasADi AD on the whole symbolic problem" + (f" ({reason})" if reason else "")
        margins = None if self.constraints is None else self.constraints.margins
        self.context = SolveContext(problem, self.path, margins)
        self.lam_x, self.lam_g = np.zeros(problem.n_vars), np.zeros(g.numel())

    def prepare(self, lbx: np.ndarray, ubx: np.ndarray) -> None:
        """Nothing is built per pattern: the NLP solver was built whole."""

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        start = time.perf_counter()
        lbg, ubg = self.problem.lb, self.problem.ub
        if self.constraints is not None:
            lower = self.constraints.lower(np.where(lbx < ubx, x0, lbx), p)
            lbg, ubg = np.r_[lbg, lower], np.r_[ubg, np.full(lower.size, np.inf)]
        out = self.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p, lam_x0=self.lam_x, lam_g0=self.lam_g)
        elapsed = time.perf_counter() - start
        stats = self.solver.stats()
        if stats["success"]:
            self.lam_x, self.lam_g = np.array(out["lam_x"]).ravel(), np.array(out["lam_g"]).ravel()
        return SolveResult(
            np.array(out["x"]).ravel(),
            bool(stats["success"]),
            str(stats["return_status"]),
            int(stats.get("iter_count", -1)),
            elapsed,
            0.0,
            self.context,
            p.copy(),
            lbx.copy(),
            ubx.copy(),
        )
