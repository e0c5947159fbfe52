"""harmony's CasADi layer: solve a built MPC problem with real equality rows, lbx/ubx bounds and warm starts.

OpTaS builds the problem (variables, parameters, named cost terms); solving through its own wrapper costs
3-5x (every equality becomes two rows, every bound a row, no dual warm start), so we call CasADi directly.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as cs
import numpy as np

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
    solve_time: float  # wall seconds of the solver call only


@dataclass
class Problem:
    """A built MPC problem: f = sum of named terms = ||r_task(q_k)||^2 summed over knots + ||L x + c||^2."""

    x: cs.SX
    p: cs.SX
    terms: dict[str, cs.SX]
    A: np.ndarray  # linear rows lb <= A x <= ub (constant)
    lb: np.ndarray
    ub: np.ndarray
    row_names: dict[str, slice]
    # Gauss-Newton structure: q_knots = X_pos @ position_basis.T with X_pos = x[:n_dof * n_pos] (column-major)
    task_residual: cs.Function  # (q[n_dof], ref[m]) -> r[m]
    position_basis: np.ndarray  # K x n_pos
    ref_shape: tuple[int, int]  # p = vec(ref) with ref m x K
    L: np.ndarray  # linear residual r_lin = L x + c
    c: np.ndarray
    build_time: float = 0.0
    term_values: cs.Function = field(init=False)

    def __post_init__(self):
        self.term_values = cs.Function("terms", [self.x, self.p], list(self.terms.values()))

    @property
    def n_vars(self) -> int:
        return self.x.numel()

    def evaluate_terms(self, x: np.ndarray, p: np.ndarray) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.terms, self.term_values(x, p))}


def linear_rows(x: cs.SX, named: dict[str, tuple]) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Stack named (expr, lb, ub) rows that must be affine in x into (A, lb, ub) with lb - A(0) offsets."""
    A, lb, ub, names, start = [], [], [], {}, 0
    for name, (expr, lo, hi) in named.items():
        if not cs.is_linear(expr, x):
            raise ValueError(f"constraint {name!r} is not linear in the decision variables")
        jac = cs.Function("row_jacobian", [x], [cs.jacobian(expr, x), expr])
        a, offset = (np.array(v) for v in jac(np.zeros(x.numel())))
        A.append(a), lb.append(np.asarray(lo) - offset.ravel()), ub.append(np.asarray(hi) - offset.ravel())
        names[name] = slice(start, start + a.shape[0])
        start += a.shape[0]
    if not A:
        return np.zeros((0, x.numel())), np.zeros(0), np.zeros(0), {}
    return np.vstack(A), np.concatenate(lb), np.concatenate(ub), names


class Buffered:
    """Zero-copy evaluation of a CasADi Function on preallocated numpy arrays of each input's/output's nonzeros.

    Converting numpy <-> DM through Python costs ~1 ms for a 108 x 108 matrix; this path costs microseconds.
    """

    def __init__(self, f: cs.Function):
        self.f = f
        self.args = {n: np.zeros(f.nnz_in(i)) for i, n in enumerate(f.name_in())}
        self.res = {n: np.zeros(f.nnz_out(i)) for i, n in enumerate(f.name_out())}
        self._buffer, self._eval = f.buffer()
        for i, n in enumerate(f.name_in()):
            self._buffer.set_arg(i, memoryview(self.args[n]))
        for i, n in enumerate(f.name_out()):
            self._buffer.set_res(i, memoryview(self.res[n]))

    def __call__(self, **inputs) -> dict[str, np.ndarray]:
        for name, value in inputs.items():
            self.args[name][:] = np.ravel(value, order="F")
        self._eval()
        return self.res

    def stats(self) -> dict:
        return self._buffer.stats()


class GaussNewtonHessian:
    """H = 2 sum_k kron(b_k b_k^T, J_k^T J_k) + 2 L^T L and the exact gradient, on the knot structure.

    The nonlinear residual of knot k depends only on q_k = X_pos b_k, so one evaluation costs K small
    Jacobians (m x n_dof) instead of one dense (mK x n_vars) one.
    """

    def __init__(self, problem: Problem):
        self.problem = problem
        B = problem.position_basis
        self.n_knots, self.n_pos = B.shape
        q = cs.SX.sym("q", problem.task_residual.size1_in(0))
        ref = cs.SX.sym("ref", problem.task_residual.size1_in(1))
        r = problem.task_residual(q, ref)
        self.n_dof, self.m = q.numel(), r.numel()
        mapped = cs.Function("res_jac", [q, ref], [r, cs.densify(cs.jacobian(r, q).T)]).map(self.n_knots)
        self.res_jac = Buffered(mapped)
        self.block_diagonal = B.shape[0] == B.shape[1] and np.allclose(B, np.eye(B.shape[0]))
        self.outer = np.einsum("ka,kb->kab", B, B)  # b_k b_k^T
        self.H_lin = 2 * problem.L.T @ problem.L
        self.g_lin0 = 2 * problem.L.T @ problem.c
        mask = np.abs(self.H_lin) > 0
        nd = self.n_dof
        if self.block_diagonal:
            for k in range(self.n_pos):
                mask[k * nd:(k + 1) * nd, k * nd:(k + 1) * nd] = True
        else:
            mask[: nd * self.n_pos, : nd * self.n_pos] = True
        self.mask = mask | np.eye(problem.n_vars, dtype=bool)

    def __call__(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nd, npos, K, B = self.n_dof, self.n_pos, self.n_knots, self.problem.position_basis
        X = x[: nd * npos].reshape((nd, npos), order="F")
        out = self.res_jac(i0=X @ B.T, i1=p)
        r = out["o0"].reshape(K, self.m)
        Jt = out["o1"].reshape(K, self.m, nd).transpose(0, 2, 1)  # K x n_dof x m (J_k^T)
        JtJ = Jt @ Jt.transpose(0, 2, 1)
        Jtr = np.einsum("kim,km->ik", Jt, r)  # n_dof x K
        H = self.H_lin.copy()
        if self.block_diagonal:
            for k in range(K):
                H[k * nd:(k + 1) * nd, k * nd:(k + 1) * nd] += 2 * JtJ[k]
        else:
            H4 = np.tensordot(self.outer, JtJ, axes=(0, 0))  # a, b, i, j
            H[: nd * npos, : nd * npos] += 2 * H4.transpose(0, 2, 1, 3).reshape(nd * npos, nd * npos)
        g = self.H_lin @ x + self.g_lin0
        g[: nd * npos] += 2 * (Jtr @ B).ravel(order="F")
        return H, g


class _HessianCallback(cs.Callback):
    """hess_lag for nlpsol: lam_f * Gauss-Newton Hessian (constraints are linear: no curvature), upper triangle."""

    def __init__(self, hessian: GaussNewtonHessian, n_p: int, n_g: int):
        cs.Callback.__init__(self)
        self.hessian, self.n_p, self.n_g = hessian, n_p, n_g
        n = hessian.mask.shape[0]
        upper = np.triu(hessian.mask)
        self.cols, self.rows = np.nonzero(upper.T)
        self.sparsity = cs.Sparsity.triplet(n, n, self.rows.tolist(), self.cols.tolist())
        self.construct("gauss_newton_hess_lag", {})

    def get_n_in(self): return 4
    def get_n_out(self): return 1
    def get_sparsity_in(self, i):
        return cs.Sparsity.dense([self.hessian.mask.shape[0], self.n_p, 1, self.n_g][i], 1)
    def get_sparsity_out(self, i): return self.sparsity
    def has_eval_buffer(self): return True

    def eval_buffer(self, arg, res):
        x, p, lam_f = (np.frombuffer(arg[i], dtype=float) for i in range(3))
        H, _ = self.hessian(x, p)
        np.frombuffer(res[0], dtype=float)[:] = lam_f[0] * H[self.rows, self.cols]
        return 0


class NlpSolver:
    """Any CasADi nlpsol plugin (IPOPT by default), primal + dual warm-started from the previous solve.

    hessian="gauss_newton" hands the plugin the structured Gauss-Newton Hessian (the cost is a sum of squares
    and the constraints linear, so the KKT point is the same); "exact" lets CasADi differentiate twice.
    """

    def __init__(self, problem: Problem, plugin: str, options: dict, hessian: str = "gauss_newton"):
        available = available_nlp_plugins()
        if plugin not in available:
            hint = " (KNITRO needs its library on the loader path and a licence)" if plugin == "knitro" else ""
            raise SolverUnavailable(f"solver.name: {plugin!r} is not available here{hint}; available NLP plugins: "
                                    f"{', '.join(available)}; harmony modes: gauss_newton, rti")
        defaults = {"print_time": False, "record_time": True}
        if plugin == "ipopt":
            defaults |= {"ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.warm_start_init_point": "yes",
                         "ipopt.mu_init": 1e-4, "ipopt.warm_start_bound_push": 1e-6,
                         "ipopt.warm_start_mult_bound_push": 1e-6}
        elif plugin in ("sqpmethod", "feasiblesqpmethod"):
            defaults |= {"print_header": False, "print_iteration": False, "print_status": False,
                         "qpsol": "qrqp", "qpsol_options": {"print_iter": False, "print_header": False}}
        if hessian == "gauss_newton":
            self._hess = _HessianCallback(GaussNewtonHessian(problem), problem.p.numel(), problem.A.shape[0])
            defaults["hess_lag"] = self._hess
        g = cs.mtimes(cs.DM(problem.A), problem.x)
        nlp = {"x": problem.x, "p": problem.p, "f": sum(problem.terms.values()), "g": g}
        try:
            self.solver = cs.nlpsol("mpc", plugin, nlp, defaults | options)
        except RuntimeError as exc:
            raise SolverUnavailable(f"solver.name: {plugin!r} failed to initialise: {str(exc).splitlines()[-1]}; "
                                    f"available NLP plugins: {', '.join(available)}") from None
        self.problem = problem
        self.lam_x = np.zeros(problem.n_vars)
        self.lam_g = np.zeros(problem.A.shape[0])

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        start = time.perf_counter()
        sol = self.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=self.problem.lb, ubg=self.problem.ub, p=p,
                          lam_x0=self.lam_x, lam_g0=self.lam_g)
        elapsed = time.perf_counter() - start
        stats = self.solver.stats()
        if stats["success"]:
            self.lam_x, self.lam_g = np.array(sol["lam_x"]).ravel(), np.array(sol["lam_g"]).ravel()
        return SolveResult(np.array(sol["x"]).ravel(), bool(stats["success"]), str(stats["return_status"]),
                           int(stats.get("iter_count", -1)), elapsed)


class GaussNewtonSolver:
    """Gauss-Newton SQP with structured Hessians and a QP per iteration; `max_iter=1` is real-time iteration."""

    def __init__(self, problem: Problem, qp: str, max_iter: int, tol: float):
        self.problem, self.max_iter, self.tol = problem, max_iter, tol
        self.hessian = GaussNewtonHessian(problem)
        mask = self.hessian.mask
        n = problem.n_vars
        self.h_cols, self.h_rows = np.nonzero(mask.T)  # CCS order of the nonzeros
        h_sparsity = cs.Sparsity.triplet(n, n, self.h_rows.tolist(), self.h_cols.tolist())
        a_cols, a_rows = np.nonzero((problem.A != 0).T)
        a_sparsity = cs.Sparsity.triplet(*problem.A.shape, a_rows.tolist(), a_cols.tolist())
        options = {"error_on_fail": False}
        if qp == "qpoases":
            options |= {"printLevel": "none"}
        elif qp == "osqp":
            options |= {"osqp": {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "max_iter": 4000}}
        self.qp_function = cs.conic("gn_qp", qp, {"h": h_sparsity, "a": a_sparsity}, options)
        self.qp = Buffered(self.qp_function)
        self.qp.args["a"][:] = problem.A[a_rows, a_cols]
        self.regularisation = 1e-6

    def solve(self, x0, lbx, ubx, p) -> SolveResult:
        start = time.perf_counter()
        problem = self.problem
        x = np.clip(x0, lbx, ubx)
        status, success = "max_iter", False
        for it in range(1, self.max_iter + 1):
            H, g = self.hessian(x, p)
            H[np.diag_indices_from(H)] += self.regularisation
            Ax = problem.A @ x
            out = self.qp(h=H[self.h_rows, self.h_cols], g=g, lba=problem.lb - Ax, uba=problem.ub - Ax,
                          lbx=lbx - x, ubx=ubx - x)
            stats = self.qp.stats()
            if not stats["success"]:
                status, success = f"qp_failed: {stats.get('return_status', '?')}", False
                break
            dx = out["x"]
            x = x + dx
            if self.max_iter == 1:
                status, success = "rti_step", True
            elif np.max(np.abs(dx)) < self.tol:
                status, success = "converged", True
                break
        return SolveResult(x, success, status, it, time.perf_counter() - start)


def make_solver(problem: Problem, spec):
    """Solver from the scenario `solver` section."""
    if spec.name == "rti":
        return GaussNewtonSolver(problem, spec.qp, 1, spec.tol)
    if spec.name == "gauss_newton":
        return GaussNewtonSolver(problem, spec.qp, spec.max_iter, spec.tol)
    return NlpSolver(problem, spec.name, dict(spec.options), spec.hessian)
