"""harmony's CasADi layer: solve a built MPC problem with real equality rows, lbx/ubx bounds and warm starts.

OpTaS builds the problem (variables, parameters, named cost terms); solving through its own wrapper costs
3-5x (every equality becomes two rows, every bound a row, no dual warm start), so we call CasADi directly.
Speed: derivatives come from the knot structure (per-knot C code), fixed variables are eliminated, and
arrays cross into CasADi without copies.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as cs
import numpy as np
import scipy.sparse as sp

from harmony_cli.knot_derivatives import Buffered, KnotConstraints, KnotDerivatives
from harmony_cli.native_oracle import native_oracle

NLP_CANDIDATES = ("ipopt", "sqpmethod", "feasiblesqpmethod", "blocksqp", "fatrop", "bonmin", "uno", "knitro",
                  "snopt", "worhp", "madnlp")


def available_nlp_plugins() -> tuple[str, ...]:
    """CasADi NLP plugins that load on this machine (KNITRO only with its library present)."""
    return tuple(n for n in NLP_CANDIDATES if cs.has_nlpsol(n))


class SolverUnavailable(RuntimeError):
    pass


@dataclass(frozen=True)
class SolveResult:
    x: np.ndarray
    success: bool
    status: str
    iterations: int
    solve_time: float  # wall seconds of the solve, excluding build_time
    build_time: float = 0.0  # wall seconds spent in this call building solver structures (first use of a pattern)


@dataclass
class Problem:
    """A built MPC problem: f = sum of named terms = ||r_task(q_k)||^2 summed over knots + ||L x + c + S p||^2,
    subject to lb <= A x <= ub and, if `constraint` is given, constraint(q_k, ref_k) >= 0 at knots k >= 1."""

    x: cs.SX
    p: cs.SX
    terms: dict[str, cs.SX]
    A: np.ndarray  # linear rows lb <= A x <= ub (constant)
    lb: np.ndarray
    ub: np.ndarray
    # Gauss-Newton structure: q_knots = X_pos @ position_basis.T with X_pos = x[:n_dof * n_pos] (column-major)
    task_residual: cs.Function  # (q[n_dof], ref[m]) -> r[m]
    position_basis: np.ndarray  # K x n_pos
    ref_shape: tuple[int, int]  # p = vec(ref) with ref m x K
    L: np.ndarray  # linear residual r_lin = L x + c + S p
    c: np.ndarray
    S: np.ndarray | None = None  # None: no parameters in the linear residual
    constraint: cs.Function | None = None  # (q[n_dof], ref[m]) -> h, e.g. obstacle clearance margins
    term_values: cs.Function = field(init=False)

    def __post_init__(self):
        self.term_values = cs.Function("terms", [self.x, self.p], list(self.terms.values()))

    @property
    def n_vars(self) -> int:
        return self.x.numel()

    def evaluate_terms(self, x: np.ndarray, p: np.ndarray) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.terms, self.term_values(x, p))}


def linear_rows(x: cs.SX, named: dict[str, tuple]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stack named (expr, lb, ub) rows that must be affine in x into (A, lb, ub) with lb - A(0) offsets."""
    A, lb, ub = [], [], []
    for name, (expr, lo, hi) in named.items():
        if not cs.is_linear(expr, x):
            raise ValueError(f"constraint {name!r} is not linear in the decision variables")
        jac = cs.Function("row_jacobian", [x], [cs.jacobian(expr, x), expr])
        a, offset = (np.array(v) for v in jac(np.zeros(x.numel())))
        A.append(a), lb.append(np.asarray(lo) - offset.ravel()), ub.append(np.asarray(hi) - offset.ravel())
    if not A:
        return np.zeros((0, x.numel())), np.zeros(0), np.zeros(0)
    return np.vstack(A), np.concatenate(lb), np.concatenate(ub)


class _Oracle(cs.Callback):
    """(x, p) -> f, (f, gradient) or Hessian (full symmetric pattern) from a KnotDerivatives."""

    def __init__(self, model: KnotDerivatives, kind: str, n_p: int):
        cs.Callback.__init__(self)
        self.model, self.kind, self.sizes, n = model, kind, (model.n_vars, n_p), model.n_vars
        self.out = {"f": [cs.Sparsity.dense(1)], "grad": [cs.Sparsity.dense(1), cs.Sparsity.dense(n)],
                    "hess": [cs.Sparsity.triplet(n, n, model.rows.tolist(), model.cols.tolist())]}[kind]
        self.construct(f"structured_{kind}", {})

    def get_n_in(self): return 2
    def get_n_out(self): return len(self.out)
    def get_sparsity_in(self, i): return cs.Sparsity.dense(self.sizes[i])
    def get_sparsity_out(self, i): return self.out[i]
    def has_eval_buffer(self): return True
    def has_reverse(self, n_adj): return self.kind == "f" and n_adj == 1

    def get_reverse(self, n_adj, name, inames, onames, opts):  # df = gradient dx (nlpsol builds nlp_grad with it)
        x, p, f, adj = (cs.MX.sym(v, s) for v, s in zip("xpfa", (*self.sizes, 1, 1)))
        return cs.Function(name, [x, p, f, adj], [adj * self.grad(x, p)[1], cs.MX(self.sizes[1], 1)], inames, onames)

    def eval_buffer(self, arg, res):  # CasADi passes None for zero inputs and for outputs it does not want
        x, p = (np.zeros(n) if a is None else np.frombuffer(a, dtype=float) for n, a in zip(self.sizes, arg))
        values = {"f": lambda: [self.model.value(x, p)], "grad": lambda: self.model.gradient(x, p),
                  "hess": lambda: [self.model.hessian(x, p)]}[self.kind]()
        for buffer, value in zip(res, values):
            if buffer is not None:
                np.frombuffer(buffer, dtype=float)[:] = value
        return 0


class _ConstraintOracle(cs.Callback):
    """(x, p) -> (h, dh/dx) ("jac"), or (x, p, lam) -> Hessian of lam . h on the cost Hessian's pattern ("hess"),
    from KnotConstraints (Python: these rows exist only with obstacles; the cost keeps its native oracle)."""

    def __init__(self, constraints: KnotConstraints, model: KnotDerivatives, kind: str, n_p: int):
        cs.Callback.__init__(self)
        self.constraints, self.model, self.kind, n = constraints, model, kind, model.n_vars
        self.sizes = (n, n_p) if kind == "jac" else (n, n_p, constraints.n_rows)
        rows, cols = np.nonzero(constraints.pattern)
        self.jac_order = np.lexsort((rows, cols))  # CCS order of the Jacobian's nonzeros
        self.jac_index = rows[self.jac_order], cols[self.jac_order]
        self.out = {"jac": [cs.Sparsity.dense(constraints.n_rows),
                            cs.Sparsity.triplet(constraints.n_rows, n, *(i.tolist() for i in self.jac_index))],
                    "hess": [cs.Sparsity.triplet(n, n, model.rows.tolist(), model.cols.tolist())]}[kind]
        self.construct(f"constraint_{kind}", {})

    def get_n_in(self): return len(self.sizes)
    def get_n_out(self): return len(self.out)
    def get_sparsity_in(self, i): return cs.Sparsity.dense(self.sizes[i])
    def get_sparsity_out(self, i): return self.out[i]
    def has_eval_buffer(self): return True
    def has_reverse(self, n_adj): return self.kind == "jac" and n_adj == 1

    def get_reverse(self, n_adj, name, inames, onames, opts):  # dh^T adj (nlpsol's Lagrangian gradient)
        x, p = cs.MX.sym("x", self.sizes[0]), cs.MX.sym("p", self.sizes[1])
        h, jac = cs.MX.sym("h", self.out[0]), cs.MX.sym("jac", self.out[1])
        adj_h, adj_jac = cs.MX.sym("adj_h", self.out[0]), cs.MX.sym("adj_jac", self.out[1])
        return cs.Function(name, [x, p, h, jac, adj_h, adj_jac],
                           [cs.densify(cs.mtimes(self(x, p)[1].T, adj_h)), cs.MX(self.sizes[1], 1)], inames, onames)

    def eval_buffer(self, arg, res):
        x, p, *lam = (np.zeros(n) if a is None else np.frombuffer(a, dtype=float) for n, a in zip(self.sizes, arg))
        if self.kind == "jac":
            h, _, C = self.constraints.evaluate(x, p)
            values = [h, C[self.jac_index]]
        else:
            values = [self.model.assemble(self.constraints.curvature(x, p, lam[0]))]
        for buffer, value in zip(res, values):
            if buffer is not None:
                np.frombuffer(buffer, dtype=float)[:] = value
        return 0


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


class NlpSolver:
    """Any CasADi nlpsol plugin (IPOPT by default) on the reduced problem, primal + dual warm-started.

    f, gradient and Hessian come from the compiled knot structure (hessian="exact": the exact Hessian,
    "gauss_newton": the cost is a sum of squares and the constraints linear, so the KKT point is the same).
    """

    def __init__(self, problem: Problem, plugin: str, options: dict, hessian: str = "gauss_newton"):
        available = available_nlp_plugins()
        if plugin not in available:
            hint = " (KNITRO needs its library on the loader path and a licence)" if plugin == "knitro" else ""
            raise SolverUnavailable(f"solver.name: {plugin!r} is not available here{hint}; available NLP plugins: "
                                    f"{', '.join(available)}; harmony modes: gauss_newton, rti")
        defaults = {"print_time": False, "record_time": True, "calc_lam_p": False}
        if plugin == "ipopt":  # warm-started: a small initial barrier takes 3 iterations, not 5-12, to the optimum;
            # MUMPS's scaling (MC64) costs ~2 ms per solve and our KKT systems are well scaled (make bench)
            defaults |= {"ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.warm_start_init_point": "yes",
                         "ipopt.mu_init": 1e-6, "ipopt.warm_start_bound_push": 1e-6,
                         "ipopt.warm_start_mult_bound_push": 1e-6, "ipopt.mumps_permuting_scaling": 0,
                         "ipopt.mumps_scaling": 0}
        elif plugin in ("sqpmethod", "feasiblesqpmethod"):
            defaults |= {"print_header": False, "print_iteration": False, "print_status": False,
                         "qpsol": "qrqp", "qpsol_options": {"print_iter": False, "print_header": False}}
        self.problem, self.plugin, self.options = problem, plugin, defaults | options
        model = KnotDerivatives(problem, exact=hessian == "exact")
        self.native = native_oracle(model, problem.p.numel())
        if self.native is None:  # no C compiler: the same derivatives through Python callbacks (~3 ms per solve)
            self.oracle = [_Oracle(model, kind, problem.p.numel()) for kind in ("f", "grad", "hess")]
            self.oracle[0].grad = self.oracle[1]
        self.constraints = KnotConstraints(problem) if problem.constraint is not None else None
        self.n_rows = 0 if self.constraints is None else self.constraints.n_rows
        if self.constraints is not None:
            self.constraint_oracle = [_ConstraintOracle(self.constraints, model, kind, problem.p.numel())
                                      for kind in ("jac", "hess")]
        self.lam_x, self.lam_g = np.zeros(problem.n_vars), np.zeros(problem.A.shape[0] + self.n_rows)
        self._solvers = {}
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
                hess_lag += self.constraint_oracle[1](x, p, lam_g[r.a.size:])[idx, idx]
            triu = cs.triu if self.plugin in ("ipopt", "bonmin", "knitro") else (lambda h: h)  # their convention
            derivatives = {  # whichever of these the plugin takes
                "grad_f": cs.Function("grad_f", [z, pe], [f_grad, grad]),
                "jac_g": cs.Function("jac_g", [z, pe], [g, jac]),
                "jac_fg": cs.Function("jac_fg", [z, pe], [f_grad, grad, g, jac]),
                "hess_lag": cs.Function("hess_lag", [z, pe, lam_f, lam_g], [triu(hess_lag)])}
            options = self.options | {k: v for k, v in derivatives.items() if k in cs.nlpsol_options(self.plugin)}
            try:
                solver = Buffered(cs.nlpsol("mpc", self.plugin, {"x": z, "p": pe, "f": f, "g": g}, options))
            except RuntimeError as exc:
                raise SolverUnavailable(f"solver.name: {self.plugin!r} failed to initialise: "
                                        f"{str(exc).splitlines()[-1]}") from None
            self._solvers[free.tobytes()] = solver, r
        return self._solvers[free.tobytes()]

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
        out = solver(x0=x0[free], lbx=lbx[free], ubx=ubx[free], lbg=lbg, ubg=ubg, p=np.r_[p, lbx[~free]],
                     lam_x0=self.lam_x[free], lam_g0=self.lam_g[rows])
        stats = solver.stats()
        x[free] = out["x"]
        if stats["success"]:
            self.lam_x[:], self.lam_g[:] = 0.0, 0.0
            self.lam_x[free], self.lam_g[rows] = out["lam_x"], out["lam_g"]
        return SolveResult(x, bool(stats["success"]), str(stats["return_status"]), int(stats.get("iter_count", -1)),
                           time.perf_counter() - start, build_time)


class SymbolicNlpSolver:
    """For plugins that differentiate the problem themselves (e.g. blocksqp): CasADi's AD on the full SX problem,
    fixed variables as lbx == ubx. Slower than NlpSolver; used only when a plugin rejects its structured oracles."""

    def __init__(self, problem: Problem, plugin: str, options: dict):
        self.constraints = KnotConstraints(problem) if problem.constraint is not None else None
        g = cs.mtimes(cs.DM(problem.A), problem.x)
        if self.constraints is not None:
            (K, npos), nd = problem.position_basis.shape, self.constraints.n_dof
            q = cs.mtimes(cs.reshape(problem.x[: nd * npos], nd, npos), cs.DM(problem.position_basis.T))
            h = problem.constraint.map(K)(q, cs.reshape(problem.p, problem.ref_shape[0], K))
            g = cs.vertcat(g, cs.vec(h[:, 1:]))
        nlp = {"x": problem.x, "p": problem.p, "f": sum(problem.terms.values()), "g": g}
        try:
            self.solver = cs.nlpsol("mpc", plugin, nlp, {"print_time": False} | options)
        except RuntimeError as exc:
            raise SolverUnavailable(f"solver.name: {plugin!r} failed to initialise: "
                                    f"{str(exc).splitlines()[-1]}") from None
        self.problem = problem
        self.lam_x, self.lam_g = np.zeros(problem.n_vars), np.zeros(g.numel())

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
        return SolveResult(np.array(out["x"]).ravel(), bool(stats["success"]), str(stats["return_status"]),
                           int(stats.get("iter_count", -1)), elapsed)


class GaussNewtonSolver:
    """Gauss-Newton SQP with structured Hessians and a QP per iteration over the free variables (see Reduction);
    nonlinear constraint rows are linearised at each iterate. `max_iter=1` is real-time iteration."""

    def __init__(self, problem: Problem, qp: str, max_iter: int, tol: float):
        self.problem, self.max_iter, self.tol = problem, max_iter, tol
        self.model = KnotDerivatives(problem)
        self.constraints = KnotConstraints(problem) if problem.constraint is not None else None
        self.qp_name, self.options = qp, {"error_on_fail": False}
        if qp == "qpoases":
            self.options |= {"printLevel": "none"}
        elif qp == "osqp":
            self.options |= {"osqp": {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "max_iter": 4000}}
        self._qps = {}
        self.regularisation = 1e-6

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
            from_c = np.flatnonzero(~from_a), (codes.data[~from_a] - 1).astype(int)
            self._qps[free.tobytes()] = solver, r, kept, np.flatnonzero(rows[kept] == cols[kept]), from_c
        return self._qps[free.tobytes()]

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        built = time.perf_counter()
        free = lbx < ubx
        qp, r, kept, diagonal, (c_slots, c_entries) = self._qp(free)
        start = time.perf_counter()
        build_time = start - built  # microseconds unless this pattern is new
        x = np.clip(x0, lbx, ubx)  # the fixed variables are exact from here on
        status, success = "max_iter", False
        for it in range(1, self.max_iter + 1):
            _, g, vals = self.model.evaluate(x, p)
            h = vals[kept]
            h[diagonal] += self.regularisation
            lba, uba = r.rows(self.problem.lb, self.problem.ub, x)
            if self.constraints is not None:  # h + C dz >= lower
                value, lower, C = self.constraints.evaluate(x, p)
                qp.args["a"][c_slots] = C[:, free].ravel()[c_entries]
                lba, uba = np.r_[lba, lower - value], np.r_[uba, np.full(value.size, np.inf)]
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
        return SolveResult(x, success, status, it, time.perf_counter() - start, build_time)


def qp_solver_for(qp: str, n_vars: int, real_time_iteration: bool) -> str:
    """`auto`: dense active-set DAQP for small QPs (Bezier); sparse solvers for large ones (traditional K=26):
    OSQP for one RTI step, proxqp for SQP, where OSQP's accuracy stalls the step-size convergence test."""
    if qp != "auto":
        return qp
    if n_vars <= 300:
        return "daqp"
    return "osqp" if real_time_iteration else "proxqp"


def make_solver(problem: Problem, spec):
    """Solver from the scenario `solver` section."""
    if spec.name == "rti":
        return GaussNewtonSolver(problem, qp_solver_for(spec.qp, problem.n_vars, True), 1, spec.tol)
    if spec.name == "gauss_newton":
        return GaussNewtonSolver(problem, qp_solver_for(spec.qp, problem.n_vars, False), spec.max_iter, spec.tol)
    try:
        return NlpSolver(problem, spec.name, dict(spec.options), spec.hessian)
    except SolverUnavailable:
        if spec.name not in available_nlp_plugins():
            raise
        return SymbolicNlpSolver(problem, spec.name, dict(spec.options))
