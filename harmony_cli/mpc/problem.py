"""The contract between an MPC and its solver: a built Problem in, a SolveResult out (after qpsolvers)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import casadi as cs
import numpy as np

from harmony_cli.mpc.codegen import Buffered, Compiling
from harmony_cli.mpc.far_rows import FarRows

# (x, p) -> (constraint rows at knots >= 1, their lower bounds)
Margins = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


class NoPlanToHold(RuntimeError):
    """An MPC's first solve failed: there is no earlier plan to hold, so the run cannot go on (a solver fault)."""


@dataclass
class Problem:
    """A built MPC problem: f = sum of named terms = ||r_task(q_k)||^2 summed over knots + ||L x + c + S p||^2,
    subject to lb <= A x <= ub and, if `constraint` is given, constraint(q_k, ref_k) >= lower at knots k >= 1
    with lower = min(0, constraint(q_0, ref_0)) (a state already inside a margin may stay but not go deeper)."""

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
    # the last rows of h, each a soft-min over many points (the arms'): their Jacobian is taken in reverse mode,
    # one sweep per row, where forward mode would take one per joint
    reverse_rows: int = 0
    far: FarRows | None = None  # those last rows, left unevaluated where a bound shows they cannot bind
    term_values: cs.Function = field(init=False)
    constraint_at_knots: cs.Function | None = field(init=False)
    _terms: Compiling | None = field(init=False, default=None, repr=False)
    # what solvers derive from the problem once and share (knot maps, compiled code), by kind: no solver state
    derived: dict = field(init=False, default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        self.term_values = cs.Function("terms", [self.x, self.p], list(self.terms.values()))
        K = self.position_basis.shape[0]
        self.constraint_at_knots = None if self.constraint is None else self.constraint.map(K)

    @property
    def n_vars(self) -> int:
        return self.x.numel()

    def compile_terms(self) -> None:
        """Start compiling the named cost terms (the steps log has them every step) in the background; until the
        library is there, CasADi's VM evaluates them. The two agree to the bit (the same IEEE operations in the
        same order; gcc without -ffast-math), so when the switch happens changes nothing but the time: ~0.03 ms
        compiled, ~0.45 ms in the VM for K = 26 with obstacles (gcc: ~6 s once)."""
        if self._terms is None:
            self._terms = Compiling(self.term_values)

    @cached_property
    def _compiled_terms(self) -> Buffered:
        assert self._terms is not None
        return Buffered(self._terms.function)

    def evaluate_terms(self, x: np.ndarray, p: np.ndarray) -> dict[str, float]:
        """Every named cost term at (x, p)."""
        if self._terms is None or not self._terms.ready:
            return {k: float(v) for k, v in zip(self.terms, self.term_values(x, p))}
        out = self._compiled_terms(i0=x, i1=p)
        return {k: float(v[0]) for k, v in zip(self.terms, out.values())}

    def knot_positions(self, x: np.ndarray) -> np.ndarray:
        """q at the knots (n_dof x K) of a solution x."""
        n_pos = self.position_basis.shape[1]
        n_dof = self.task_residual.size1_in(0)
        return x[: n_dof * n_pos].reshape((n_dof, n_pos), order="F") @ self.position_basis.T

    def max_violation(
        self, x: np.ndarray, p: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, margins: Margins | None = None
    ) -> float:
        """The largest violation of any bound, linear row or constraint row by x [their units]; `margins` gives
        the constraint rows and their lower bounds from compiled code (else CasADi's VM evaluates them)."""
        Ax = self.A @ x
        parts = [lbx - x, x - ubx, self.lb - Ax, Ax - self.ub]
        if margins is not None:
            h, lower = margins(x, p)
            parts.append(lower - h)
        elif self.constraint_at_knots is not None:
            h = np.array(self.constraint_at_knots(self.knot_positions(x), p.reshape(self.ref_shape, order="F")))
            parts.append(np.minimum(h[:, :1], 0.0) - h[:, 1:])
        return float(max(0.0, *(np.max(v, initial=0.0) for v in parts)))


@dataclass(frozen=True)
class SolveContext:
    """What every result of one solver shares: its problem, the code path it takes and its compiled rows."""

    problem: Problem
    path: str  # e.g. "ipopt: cost through the native C oracle ..., clearance rows through Python callbacks"
    margins: Margins | None = None  # the solver's compiled constraint rows, for the violation


@dataclass(frozen=True)
class SolveResult:
    """One solve. `cost_terms` and `max_violation` are evaluated on first use, outside the timed solve."""

    x: np.ndarray
    success: bool
    status: str
    iterations: int
    solve_time: float  # wall seconds of the solve, excluding build_time
    build_time: float = 0.0  # wall seconds spent in this call building solver structures (first use of a pattern)
    context: SolveContext | None = field(default=None, repr=False, compare=False)
    p: np.ndarray | None = field(default=None, repr=False, compare=False)  # the parameters and bounds it solved
    lbx: np.ndarray | None = field(default=None, repr=False, compare=False)  # with (copies)
    ubx: np.ndarray | None = field(default=None, repr=False, compare=False)
    qp_rows: int = 0  # rows of the QPs solved, summed over iterations (harmony's Gauss-Newton modes)
    qp_solves: int = 0  # QPs solved (more than the iterations when a screened QP had to add rows)

    @property
    def path(self) -> str:
        return "" if self.context is None else self.context.path

    @cached_property
    def cost_terms(self) -> dict[str, float]:
        """Every named cost term at x."""
        if self.context is None or self.p is None:
            return {}
        return self.context.problem.evaluate_terms(self.x, self.p)

    @cached_property
    def max_violation(self) -> float:
        """The largest violation of the bounds, linear rows and constraint rows at x (0: feasible)."""
        if self.context is None or self.p is None or self.lbx is None or self.ubx is None:
            return float("nan")
        return self.context.problem.max_violation(self.x, self.p, self.lbx, self.ubx, self.context.margins)


class Solver(Protocol):
    """Solves one Problem again and again from new (x0, bounds, parameters), warm-started."""

    @property
    def path(self) -> str:
        """What runs, e.g. "ipopt: native C oracle, clearance rows through Python callbacks"."""

    def solve(self, x0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, p: np.ndarray) -> SolveResult: ...

    def prepare(self, lbx: np.ndarray, ubx: np.ndarray) -> None:
        """Build what a solve with these bounds' pattern of free variables builds on first use (before a loop's
        clock starts); what any solve finds is unchanged."""


def dense(m: cs.DM) -> np.ndarray:
    """A DM as a numpy array, from its nonzeros (np.array(m) walks every element in Python: ~0.2 s for the
    parameter Jacobian of a problem with obstacles)."""
    sparsity, out = m.sparsity(), np.zeros(m.shape)
    cols = np.repeat(np.arange(m.shape[1]), np.diff(np.asarray(sparsity.colind(), dtype=int)))
    out[np.asarray(sparsity.row(), dtype=int), cols] = np.asarray(m.nonzeros(), dtype=float)
    return out


def linear_rows(x: cs.SX, named: dict[str, tuple]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stack named (expr, lb, ub) rows that must be affine in x into (A, lb, ub) with lb - A(0) offsets."""
    A, lb, ub = [], [], []
    for name, (expr, lo, hi) in named.items():
        if not cs.is_linear(expr, x):
            raise ValueError(f"constraint {name!r} is not linear in the decision variables")
        jac = cs.Function("row_jacobian", [x], [cs.jacobian(expr, x), expr])
        a, offset = (dense(v) for v in jac(np.zeros(x.numel())))
        A.append(a)
        lb.append(np.asarray(lo) - offset.ravel())
        ub.append(np.asarray(hi) - offset.ravel())
    if not A:
        return np.zeros((0, x.numel())), np.zeros(0), np.zeros(0)
    return np.vstack(A), np.concatenate(lb), np.concatenate(ub)
