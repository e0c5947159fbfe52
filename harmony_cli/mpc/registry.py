"""Which solvers harmony offers, in one place: its own Gauss-Newton modes and the CasADi NLP plugins that load on
this machine (solvers.py's `make_solver` builds one for a problem). casadi loads only inside the functions that
ask it, so that validating a scenario stays light."""

from __future__ import annotations

from typing import Literal, get_args

HARMONY_SOLVERS = {
    "gauss_newton": "Gauss-Newton SQP to convergence, one QP per iteration",
    "rti": "real-time iteration: one Gauss-Newton QP per control step",
}
NLP_CANDIDATES = (
    "ipopt",
    "sqpmethod",
    "feasiblesqpmethod",
    "blocksqp",
    "fatrop",
    "bonmin",
    "uno",
    "knitro",
    "snopt",
    "worhp",
    "madnlp",
)
QpName = Literal["daqp", "qpoases", "osqp", "proxqp"]
QP_SOLVERS: tuple[str, ...] = get_args(QpName)
HINTS = {"knitro": "the KNITRO plugin needs libknitro on the loader path and a licence"}


class SolverUnavailable(RuntimeError):
    """A solver that cannot be used here; the message is one line naming solver.name, the value and the choices."""


def available_nlp_plugins() -> tuple[str, ...]:
    """CasADi NLP plugins that load on this machine (KNITRO only with its library present)."""
    import casadi as cs

    return tuple(n for n in NLP_CANDIDATES if cs.has_nlpsol(n))


def available_solvers() -> tuple[str, ...]:
    """Every valid solver.name here: harmony's modes, then the NLP plugins that load."""
    return tuple(HARMONY_SOLVERS) + available_nlp_plugins()


def unavailable_message(name: str) -> str:
    """One line: solver.name, the value, why (a hint where one is known) and the valid choices."""
    hint = f" ({HINTS[name]})" if name in HINTS else ""
    return (
        f"solver.name: {name!r} is not available on this machine{hint}; choose one of: {', '.join(available_solvers())}"
    )


def qp_solver_for(qp: str, n_vars: int, real_time_iteration: bool) -> str:
    """`auto`: dense active-set DAQP for small QPs (Bezier); sparse solvers for large ones (traditional K=26):
    OSQP for one RTI step, proxqp for SQP, where OSQP's accuracy stalls the step-size convergence test."""
    if qp != "auto":
        return qp
    if n_vars <= 300:
        return "daqp"
    return "osqp" if real_time_iteration else "proxqp"


def options_problem(name: str, options: dict) -> str | None:
    """What is wrong with `solver.options` for solver `name` (None: nothing), found the way a run would find it:
    CasADi builds the plugin on a one-variable problem with them (unknown options, wrong types, an unknown
    IPOPT option). Harmony's own modes take no options (their fields are max_iter, tol, qp)."""
    import re

    import casadi as cs

    from harmony_cli.capture import captured_output

    if not options:
        return None
    if name in HARMONY_SOLVERS:
        return f"{name} takes no options (its settings are solver.max_iter, solver.tol, solver.qp)"
    x = cs.MX.sym("x")
    try:
        with captured_output():
            cs.nlpsol("options_check", name, {"x": x, "f": x * x}, {"print_time": False} | options)
    except Exception as exc:  # noqa: BLE001 - CasADi raises RuntimeError (or TypeError for odd values)
        lines = [re.sub(r"^.*\.cpp:\d+: ", "", line).strip() for line in str(exc).splitlines()]
        guesses = re.findall(r'^> "([^"]+)"', str(exc), flags=re.M)
        said = [s for s in lines if s and not s.startswith(("Error calling", "Use print_options", "Did you", ">"))]
        return " ".join(said) + (f"; did you mean one of: {', '.join(guesses)}" if guesses else "")
    return None
