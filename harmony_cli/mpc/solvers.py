"""A scenario's `solver` section made into a solver for a problem: harmony's own Gauss-Newton modes or an NLP
plugin of CasADi's (registry.py names them)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from harmony_cli.mpc.gauss_newton import GaussNewtonSolver
from harmony_cli.mpc.nlp import NlpSolver, SymbolicNlpSolver
from harmony_cli.mpc.registry import (
    HARMONY_SOLVERS,
    SolverUnavailable,
    available_nlp_plugins,
    qp_solver_for,
    unavailable_message,
)

if TYPE_CHECKING:
    from harmony_cli.mpc.problem import Problem, Solver
    from harmony_cli.scenario.models import SolverSpec


def make_solver(problem: Problem, spec: SolverSpec) -> Solver:
    """The solver of a scenario's `solver` section. An NLP plugin that rejects harmony's structured oracles
    gets CasADi's AD on the whole problem instead (slower; its `path` says so and why)."""
    if spec.name in HARMONY_SOLVERS:
        rti = spec.name == "rti"
        qp = qp_solver_for(spec.qp, problem.n_vars, rti)
        return GaussNewtonSolver(problem, qp, 1 if rti else spec.max_iter, spec.tol, spec.name, spec.damping)
    if spec.name not in available_nlp_plugins():
        raise SolverUnavailable(unavailable_message(spec.name))
    try:
        return NlpSolver(problem, spec.name, dict(spec.options), spec.hessian)
    except SolverUnavailable as exc:
        return SymbolicNlpSolver(problem, spec.name, dict(spec.options), reason=str(exc))
