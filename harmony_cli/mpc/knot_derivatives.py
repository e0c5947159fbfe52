"""Cost derivatives on the knot structure, evaluated in compiled C without copies.

The nonlinear residual of knot k depends only on q_k = X_pos b_k, so f, its gradient and its Hessian
(Gauss-Newton or exact) cost K small per-knot derivatives instead of one dense (mK x n_vars) Jacobian.
"""

from __future__ import annotations

from functools import cached_property

import casadi as cs
import numpy as np
import scipy.sparse as sp

from harmony_cli.mpc.codegen import Buffered, Compiling, code_path
from harmony_cli.mpc.problem import Problem


class KnotDerivatives:
    """f, gradient and H = sum_k kron(b_k b_k^T, H_k) + 2 L^T L on the knot structure, with H_k = 2 J_k^T J_k
    (Gauss-Newton) or, if exact, the Hessian of ||r_k(q_k)||^2 (then H is the exact Hessian of f).

    The residual of knot k depends only on q_k = X_pos b_k: one evaluation is K small per-knot derivatives in
    compiled C. H is kept as values on a fixed pattern: nonzero i sits at (rows[i], cols[i]), in CCS order.
    The maps compile in the background from construction (`compile_now=False`: from their first use).
    """

    def __init__(self, problem: Problem, exact: bool = False, compile_now: bool = True):
        self.B, self.exact, (K, npos), n = problem.position_basis, exact, problem.position_basis.shape, problem.n_vars
        q, ref = (cs.SX.sym(name, problem.task_residual.size1_in(i)) for i, name in enumerate(("q", "ref")))
        r = problem.task_residual(q, ref)
        self.n_dof, self.m, self.n_vars, nd = q.numel(), r.numel(), n, q.numel()
        J = cs.jacobian(r, q)
        knot_maps = {
            "value": [r],
            "gradient": [r, cs.densify(J.T)],  # the native oracle's (native_oracle.py)
            # r, J^T r and J^T J per knot: the normal equations' parts in C, where J's zeros cost nothing
            "normal": [r, cs.densify(cs.mtimes(J.T, r)), cs.densify(cs.mtimes(J.T, J))],
            "hessian": [cs.densify(cs.hessian(cs.sumsqr(r), q)[0])],
        }
        # line-search trial points need f only, gradients r, J^T r and J^T J; the exact per-knot Hessians cost the most
        self.knot_functions = {
            kind: cs.Function(f"harmony_{kind}", [q, ref], outs).map(K)
            for kind, outs in knot_maps.items()
            if kind != "hessian" or exact
        }
        if compile_now:
            self._compiling  # noqa: B018 - gcc from now on, in the background
        self._cache: dict[str, tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]] = {}
        self.native: dict[int, cs.Function | None] = {}  # parameters -> the native oracle (native_oracle.py)
        self.L, self.Lt, self.c = sp.csr_matrix(problem.L), sp.csr_matrix(problem.L.T), problem.c
        self.S = sp.csr_matrix(problem.S if problem.S is not None else (problem.c.size, problem.p.numel()))
        # block (a, b) of the position Hessian is sum_k B[k, a] B[k, b] H_k; (b, a) is the same matrix (H_k
        # symmetric), so one block per unordered nonzero pair
        outer = np.einsum("ka,kb->kab", self.B, self.B)
        a, b = np.nonzero(np.abs(outer).max(axis=0) > 0)
        upper, i = a <= b, np.arange(nd)
        self.W = outer[:, a[upper], b[upper]].T
        block = np.zeros((npos, npos), dtype=int)
        block[a[upper], b[upper]] = block[b[upper], a[upper]] = np.arange(upper.sum())
        nl_rows = ((a * nd)[:, None, None] + i[:, None] + 0 * i).ravel()  # (pair, i, j) order
        nl_cols = ((b * nd)[:, None, None] + 0 * i[:, None] + i).ravel()
        nl_entry = ((block[a, b] * nd * nd)[:, None, None] + i[:, None] * nd + i).ravel()
        H_lin = (2 * self.Lt @ self.L).tocoo()
        rows, cols = np.r_[nl_rows, H_lin.row, np.arange(n)], np.r_[nl_cols, H_lin.col, np.arange(n)]
        pattern = sp.csc_matrix((np.ones(rows.size), (rows, cols)), (n, n))
        pattern.sort_indices()
        self.rows, self.cols = pattern.indices, np.repeat(np.arange(n), np.diff(pattern.indptr))
        self.lin_vals = np.asarray(H_lin.tocsr()[self.rows, self.cols]).ravel()
        n_blocks = self.W.shape[0] * nd * nd
        lookup = np.full((n, n), n_blocks)
        lookup[nl_rows, nl_cols] = nl_entry
        self.nl_index = lookup[self.rows, self.cols]  # into the flat knot blocks, then a trailing zero
        self._blocks = np.zeros(n_blocks + 1)

    @cached_property
    def _compiling(self) -> dict[str, Compiling]:
        return {kind: Compiling(f) for kind, f in self.knot_functions.items()}

    @cached_property
    def knots(self) -> dict[str, Buffered]:
        """The compiled per-knot maps by kind (the first use waits for gcc)."""
        return {kind: Buffered(c.function) for kind, c in self._compiling.items()}

    @property
    def code_path(self) -> str:
        """compiled C, or CasADi's VM without gcc."""
        return code_path(self._compiling["value"].function)

    def _knots(self, kind: str, x: np.ndarray, p: np.ndarray) -> dict[str, np.ndarray]:
        """Per-knot outputs of one kind at (x, p), cached for the last point asked of that kind: the map's own
        output buffers, valid until the next evaluation of that kind (every caller reads them at once)."""
        hit = self._cache.get(kind)
        if hit is None or not (np.array_equal(x, hit[0]) and np.array_equal(p, hit[1])):
            nd, npos = self.n_dof, self.B.shape[1]
            out = self.knots[kind](i0=x[: nd * npos].reshape((nd, npos), order="F") @ self.B.T, i1=p)
            hit = self._cache[kind] = x.copy(), p.copy(), out
        return hit[2]

    def reset(self) -> None:
        """Forget the last points evaluated (a new solver's first evaluation computes)."""
        self._cache.clear()

    def linear_residual(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        return self.L @ x + self.c + self.S @ p

    def value(self, x: np.ndarray, p: np.ndarray) -> float:
        r, r_lin = self._knots("value", x, p)["o0"], self.linear_residual(x, p)
        return float(r @ r + r_lin @ r_lin)

    def gradient(self, x: np.ndarray, p: np.ndarray) -> tuple[float, np.ndarray]:
        return self._gradient(self._knots("normal", x, p), x, p)

    def _gradient(self, out: dict[str, np.ndarray], x: np.ndarray, p: np.ndarray) -> tuple[float, np.ndarray]:
        """`gradient` from the normal map's outputs at (x, p)."""
        nd, (K, npos) = self.n_dof, self.B.shape
        r, Jr = out["o0"], out["o1"].reshape(K, nd)  # J_k^T r_k, J_k = d r_k / d q_k
        r_lin = self.linear_residual(x, p)
        g = 2 * (self.Lt @ r_lin)
        g[: nd * npos] += 2 * (self.B.T @ Jr).ravel()
        return float(r @ r + r_lin @ r_lin), g

    def taking(self, nonzeros: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What `hessian` needs to give only the pattern's `nonzeros` (indices into it): made once per subset."""
        return self.nl_index[nonzeros], self.lin_vals[nonzeros]

    def hessian(self, x: np.ndarray, p: np.ndarray, taken: tuple | None = None) -> np.ndarray:
        """Hessian values on the pattern (rows, cols), or only at the nonzeros `taken` (`taking`) stands for."""
        return self._hessian(None if self.exact else self._knots("normal", x, p), x, p, taken)

    def _hessian(self, knots: dict[str, np.ndarray] | None, x, p, taken: tuple | None) -> np.ndarray:
        """`hessian` from the normal map's outputs at (x, p) (Gauss-Newton; None when exact)."""
        K = self.B.shape[0]
        if knots is None:
            H_k = self._knots("hessian", x, p)["o0"].reshape(K, -1)
        else:
            H_k = 2 * knots["o2"].reshape(K, -1)  # J_k^T J_k, symmetric: its column-major order is its row-major
        if taken is None:
            return self.lin_vals + self.assemble(H_k)
        index, linear = taken
        return linear + self.assemble(H_k, index)

    def assemble(self, H_k: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """sum_k kron(b_k b_k^T, H_k) on the pattern (rows, cols), from per-knot blocks H_k (K x n_dof^2); at the
        block entries `index` (of nl_index) if given."""
        np.matmul(self.W, H_k, out=self._blocks[:-1].reshape(self.W.shape[0], -1))
        return self._blocks[self.nl_index if index is None else index]

    def evaluate(
        self, x: np.ndarray, p: np.ndarray, taken: tuple | None = None
    ) -> tuple[float, np.ndarray, np.ndarray]:
        """(f, gradient, Hessian values), those at the nonzeros `taken` (`taking`) stands for only if given: one
        evaluation of the per-knot map serves all three."""
        out = self._knots("normal", x, p)
        return *self._gradient(out, x, p), self._hessian(None if self.exact else out, x, p, taken)

    def __call__(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Dense (H, gradient)."""
        _, g = self.gradient(x, p)
        H = np.zeros((x.size, x.size))
        H[self.rows, self.cols] = self.hessian(x, p)
        return H, g


def shared_derivatives(problem: Problem, exact: bool = False, compile_now: bool = True) -> KnotDerivatives:
    """The problem's KnotDerivatives, made once per problem and shared by the solvers built on it (its compiled
    maps are the expensive part; a run after another of the same structure builds none), reset for a new one."""
    model = problem.derived.get(("derivatives", exact))
    if model is None:
        model = problem.derived[("derivatives", exact)] = KnotDerivatives(problem, exact, compile_now)
    elif compile_now:
        model._compiling  # noqa: B018 - gcc from now on, if it has not started
    model.reset()
    return model
