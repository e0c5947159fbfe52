"""Constraint rows on the knot structure: h(q_k, ref_k) >= lower at the knots k >= 1 and their Jacobians from
compiled per-knot maps, evaluated without copies; the far rows (mpc/far_rows.py) in a map of their own."""

from __future__ import annotations

from functools import cached_property

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import Buffered, Compiling, code_path
from harmony_cli.mpc.far_rows import FarBound
from harmony_cli.mpc.problem import Problem


class KnotConstraints:
    """Nonlinear rows h(q_k, ref_k) >= lower at the knots k >= 1 (knot 0 is the measured state) and their Jacobian
    C = J_k (x) b_k over the position variables, from compiled per-knot maps (the far rows, if any, in one of their
    own: far_rows.py). Rows are knot-major:
    (k - 1) * m + j. lower = min(0, h(q_0)) per constraint: a state already inside a margin (a push, a moving
    obstacle) may stay there but not go deeper, so the problem stays feasible.

    The per-knot Hessians of the rows (`curvature`, for an NLP solver's exact Lagrangian Hessian) are compiled
    only when asked for: `curvature=True` starts gcc now, else on first use (their C takes ~20 s to compile with
    obstacles, and the Gauss-Newton modes never use them)."""

    def __init__(self, problem: Problem, curvature: bool = False):
        if problem.constraint is None:
            raise ValueError("KnotConstraints needs a problem with constraint rows")
        self.B, n, constraint = problem.position_basis, problem.n_vars, problem.constraint
        (K, npos), nd = self.B.shape, constraint.size1_in(0)
        q, ref = (cs.SX.sym(name, constraint.size1_in(i)) for i, name in enumerate(("q", "ref")))
        h = constraint(q, ref)
        self.m, self.n_dof, self.n_rows = h.numel(), nd, (K - 1) * h.numel()
        self.function, self.n_ref = constraint, constraint.size1_in(1)
        split = self.split = h.numel() - problem.reverse_rows
        J = cs.vertcat(cs.jacobian(h[:split], q), cs.jacobian(h[split:], q, {"allow_forward": False}))
        # the far rows (the arms', far_rows.py) in a map of their own, evaluated only where they could bind
        self.far_rows = problem.far
        near = split if self.far_rows is not None else h.numel()
        self._rows = Compiling(cs.Function("harmony_clearance", [q, ref], [h[:near], cs.densify(J[:near, :].T)]).map(K))
        self._far_code = None
        if self.far_rows is not None:
            rows = cs.Function("harmony_clearance_far", [q, ref], [h[split:], cs.densify(J[split:, :].T)])
            self._far_code = Compiling(rows.map(K))
        self._h, self._J = np.zeros((K, self.m)), np.zeros((K, self.m, nd))
        self._values = Compiling(cs.Function("harmony_clearance_value", [q, ref], [h]).map(K))  # for `margins`
        self._near_values = None  # `margins` where a bound shows the far rows clear: the near rows alone
        if self.far_rows is not None:
            self._near_values = Compiling(cs.Function("harmony_clearance_near_value", [q, ref], [h[:near]]).map(K))
        self._symbols = q, ref, h
        if curvature:
            self._compiling_curvature  # noqa: B018 - gcc from now on
        structural = np.array(cs.DM(J.sparsity(), 1)) != 0  # m x nd: which joints each constraint depends on
        self.pattern = np.zeros((self.n_rows, n), dtype=bool)  # x = [vec(positions) (nd * npos); anything else]
        self.pattern[:, : nd * npos] = np.einsum("ka,ji->kjai", self.B[1:] != 0, structural).reshape(self.n_rows, -1)

    @cached_property
    def map(self) -> Buffered:
        """The compiled per-knot rows and their Jacobians (the first use waits for gcc)."""
        return Buffered(self._rows.function)

    @cached_property
    def far_map(self) -> Buffered:
        """The compiled per-knot far rows and their Jacobians."""
        assert self._far_code is not None
        return Buffered(self._far_code.function)

    @cached_property
    def value_map(self) -> Buffered:
        """The compiled per-knot rows alone (half the time of `map`: no Jacobian)."""
        return Buffered(self._values.function)

    @cached_property
    def near_value_map(self) -> Buffered:
        """The compiled per-knot near rows alone, for `margins` where the far rows cannot be below their bounds."""
        assert self._near_values is not None
        return Buffered(self._near_values.function)

    @property
    def code_path(self) -> str:
        """How the rows are evaluated; waits for their C (the far rows' too: not in the loop)."""
        if self._far_code is not None:
            self._far_code.function  # noqa: B018 - waits for gcc
        return code_path(self._rows.function)

    @cached_property
    def _compiling_curvature(self) -> Compiling:
        q, ref, h = self._symbols
        lam = cs.SX.sym("lam", self.m)
        hessian = cs.densify(cs.hessian(cs.dot(lam, h), q)[0])
        return Compiling(cs.Function("harmony_clearance_hessian", [q, ref, lam], [hessian]).map(self.B.shape[0]))

    @cached_property
    def curvature_map(self) -> Buffered:
        return Buffered(self._compiling_curvature.function)

    def lower(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Lower bounds of the rows: min(0, h(q_0)) per constraint, repeated for every knot >= 1."""
        (K, npos), nd = self.B.shape, self.n_dof
        q0 = x[: nd * npos].reshape((nd, npos), order="F") @ self.B[0]
        h0 = np.array(self.function(q0, p[: self.n_ref])).ravel()
        return np.tile(np.minimum(h0, 0.0), K - 1)

    def _at_knots(self, x: np.ndarray) -> np.ndarray:
        """q at every knot (n_dof x K), the maps' first input."""
        nd, npos = self.n_dof, self.B.shape[1]
        return x[: nd * npos].reshape((nd, npos), order="F") @ self.B.T

    def _split(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h at knots >= 1, their lower bounds min(0, h(q_0))) from h at every knot (K x m, a map's buffer)."""
        return h[1:].ravel().copy(), np.tile(np.minimum(h[0], 0.0), h.shape[0] - 1)

    def knots(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """q (n_dof x K) and the parameters (m x K) at every knot."""
        K = self.B.shape[0]
        return self._at_knots(x), p[: self.n_ref * K].reshape((self.n_ref, K), order="F")

    def _rows_and_jacobians(
        self, x: np.ndarray, p: np.ndarray, bound: FarBound | None = None, step: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, bool]:
        """h (K x m) and the per-knot Jacobians J (K x m x n_dof) at every knot (views of buffers reused by the next
        call), and whether the far rows were evaluated: not where `bound` shows that no step changing the knots'
        joints by at most `step` (n_dof x K) brings them to their bounds (they read +inf, a zero Jacobian: rows
        that cannot bind); where they are, `bound` keeps their values."""
        K, split = self.B.shape[0], self.split
        q, ref = self.knots(x, p)
        out = self.map(i0=q, i1=p)
        if self.far_rows is None:
            return out["o0"].reshape(K, self.m), out["o1"].reshape(K, self.m, self.n_dof), True
        h, J = self._h, self._J
        h[:, :split], J[:, :split] = out["o0"].reshape(K, split), out["o1"].reshape(K, split, self.n_dof)
        if bound is not None and step is not None and bound.clear(q, ref, step):
            h[:, split:], J[:, split:] = np.inf, 0.0
            return h, J, False
        far = self.far_map(i0=q, i1=p)
        h[:, split:] = far["o0"].reshape(K, self.m - split)
        J[:, split:] = far["o1"].reshape(K, self.m - split, self.n_dof)
        if bound is not None:
            bound.store(q, ref, h[:, split:])
        return h, J, True

    def margins(self, x: np.ndarray, p: np.ndarray, bound: FarBound | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(h at knots >= 1, lower bounds), without the Jacobian (its own map: half the time). Where `bound` shows
        the far rows >= 0 at every knot (knot 0's too: their lower bounds are then 0), they read +inf: below their
        bounds they are not, which is all a violation asks of them."""
        K = self.B.shape[0]
        if bound is not None and self._near_values is not None:
            q, ref = self.knots(x, p)
            if bound.clear(q, ref, np.zeros_like(q)):
                h = np.full((K, self.m), np.inf)
                h[:, : self.split] = self.near_value_map(i0=q, i1=p)["o0"].reshape(K, self.split)
                h[0, self.split :] = 0.0  # lower bounds min(0, h(q_0)) of rows >= 0: 0
                return self._split(h)
        return self._split(self.value_map(i0=self._at_knots(x), i1=p)["o0"].reshape(K, self.m))

    def evaluate(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(h at knots >= 1, lower bounds, C: n_rows x n_vars dense)."""
        h, J, _ = self._rows_and_jacobians(x, p)
        C = np.zeros(self.pattern.shape)
        C[:, : J.shape[2] * self.B.shape[1]] = np.einsum("kji,ka->kjai", J[1:], self.B[1:]).reshape(self.n_rows, -1)
        return *self._split(h), C

    def jacobians(
        self, x: np.ndarray, p: np.ndarray, bound: FarBound | None = None, step: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """(h at knots >= 1, lower bounds, the per-knot Jacobians J_k at knots >= 1: (K - 1, m, n_dof), whether the
        far rows were evaluated (see _rows_and_jacobians)); C without forming it (mpc/knot_rows.py)."""
        h, J, evaluated = self._rows_and_jacobians(x, p, bound, step)
        return *self._split(h), J[1:].copy(), evaluated

    def entries(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, ...]:
        """Where the Jacobian's entries C[rows, cols] (cols: position variables) come from, for `evaluate_entries`:
        their knot, constraint and joint in the per-knot Jacobians and their control point."""
        if np.any(cols >= self.n_dof * self.B.shape[1]):
            raise ValueError("clearance rows depend on the position variables only")
        return rows // self.m + 1, rows % self.m, cols % self.n_dof, cols // self.n_dof

    def evaluate_entries(
        self, x: np.ndarray, p: np.ndarray, entries: tuple[np.ndarray, ...]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(h at knots >= 1, lower bounds, the Jacobian's values at `entries`): `evaluate` without the dense C, the
        same products J_k[j, i] b_k[a] (to the bit)."""
        h, J, _ = self._rows_and_jacobians(x, p)
        knot, row, joint, point = entries
        return *self._split(h), J[knot, row, joint] * self.B[knot, point]

    def curvature(self, x: np.ndarray, p: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Per-knot Hessians of lam . h with respect to q_k (K x n_dof^2; knot 0 has no rows: zero)."""
        out = self.curvature_map(i0=self._at_knots(x), i1=p, i2=np.r_[np.zeros(self.m), lam])
        return out["o0"].reshape(self.B.shape[0], self.n_dof**2).copy()


def shared_constraints(problem: Problem, curvature: bool = False) -> KnotConstraints:
    """The problem's KnotConstraints, made once per problem and shared (they keep no state between calls)."""
    constraints = problem.derived.get("constraints")
    if constraints is None:
        constraints = problem.derived["constraints"] = KnotConstraints(problem, curvature)
    elif curvature:
        constraints._compiling_curvature  # noqa: B018 - gcc from now on, if it has not started
    return constraints
