"""Bernstein/Bezier maths for numpy arrays and CasADi symbols.

Conventions: a curve with ``N`` control points has degree ``n = N - 1``; control
points are the columns of a ``(dim, N)`` array; normalised time ``s`` lies in
``[0, 1]`` and a horizon of ``T`` seconds gives ``d/dt = (1/T) d/ds``.
"""

from __future__ import annotations

from functools import lru_cache
from math import comb
from typing import Any

import casadi as ca
import numpy as np

__all__ = [
    "bernstein_basis",
    "difference_matrix",
    "derivative_matrix",
    "evaluate",
    "shift_matrix",
    "convex_hull_box",
]

_CASADI = (ca.SX, ca.MX, ca.DM)
_MAX_COMB = 64  # binomial coefficients C(n, j) for n < this, as floats (rounded as numpy rounds comb(n, j) * s)
_COMB = np.array([[comb(n, j) for j in range(_MAX_COMB)] for n in range(_MAX_COMB)], dtype=float)


def bernstein_basis(n_ctrl: int, s: Any) -> Any:
    """Basis matrix ``B[k, j] = C(n, j) s_k^j (1 - s_k)^(n - j)``, shape ``(K, n_ctrl)``.

    Numeric ``s`` (float, list, ndarray, DM) gives numpy; an SX/MX ``s`` gives the same type.
    """
    if n_ctrl < 1:
        raise ValueError(f"n_ctrl must be >= 1, got {n_ctrl}")
    n = n_ctrl - 1
    if not isinstance(s, (ca.SX, ca.MX)):
        powers, complements = _powers(np.asarray(s, dtype=float).reshape(-1), n)
        return (_binomials(n) * powers) * complements[:, ::-1]
    s = ca.vec(s)
    one = type(s).ones(s.size1(), 1)
    # Powers by repeated multiplication: exact at s = 0 and s = 1, no 0**0 issues.
    pw, pw1 = [one], [one]
    for _ in range(n):
        pw.append(pw[-1] * s)
        pw1.append(pw1[-1] * (1 - s))
    return ca.horzcat(*[comb(n, j) * pw[j] * pw1[n - j] for j in range(n_ctrl)])


def _powers(s: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(s^j, (1 - s)^j) for j = 0..n, (K, n + 1) each, by repeated multiplication (exact at s = 0 and 1, no 0**0;
    multiply.accumulate multiplies in order, so every power is the same float as a loop's)."""
    factors = np.empty((s.size, n + 1))
    factors[:, 0], factors[:, 1:] = 1.0, s[:, None]
    complements = np.empty((s.size, n + 1))
    complements[:, 0], complements[:, 1:] = 1.0, (1 - s)[:, None]
    return np.multiply.accumulate(factors, axis=1), np.multiply.accumulate(complements, axis=1)


@lru_cache(maxsize=32)
def _binomials(n: int) -> np.ndarray:
    return np.array([comb(n, j) for j in range(n + 1)], dtype=float)


def difference_matrix(n_ctrl: int, order: int = 1, horizon: float = 1.0) -> np.ndarray:
    """Matrix ``D`` with hodograph control points ``X @ D.T`` of the ``order``-th time derivative.

    Shape ``(n_ctrl - order, n_ctrl)``; ``(0, n_ctrl)`` when ``order >= n_ctrl``.
    """
    if n_ctrl < 1 or order < 0:
        raise ValueError(f"need n_ctrl >= 1 and order >= 0, got {n_ctrl}, {order}")
    if order >= n_ctrl:
        return np.zeros((0, n_ctrl))
    D = np.eye(n_ctrl)
    for k in range(order):
        m = n_ctrl - k  # control points of the current hodograph
        D = (m - 1) / horizon * (np.eye(m - 1, m, 1) - np.eye(m - 1, m)) @ D
    return D


def derivative_matrix(n_ctrl: int, s: Any, order: int = 0, horizon: float = 1.0) -> np.ndarray:
    """Map control points to the ``order``-th time derivative at knots ``s``: shape ``(K, n_ctrl)``."""
    s = np.asarray(s, dtype=float).ravel()
    D = difference_matrix(n_ctrl, order, horizon)
    if D.shape[0] == 0:
        return np.zeros((s.size, n_ctrl))
    return bernstein_basis(n_ctrl - order, s) @ D


def evaluate(ctrl: Any, s: Any, order: int = 0, horizon: float = 1.0) -> Any:
    """Curve (or its ``order``-th time derivative) at knots ``s``: shape ``(dim, K)``.

    ``ctrl`` may be numpy or CasADi SX/MX/DM (result has the matching type); ``s`` is numeric.
    """
    if isinstance(ctrl, _CASADI):
        return ca.mtimes(ctrl, ca.DM(derivative_matrix(ctrl.shape[1], s, order, horizon).T))
    ctrl = np.atleast_2d(np.asarray(ctrl, dtype=float))
    return ctrl @ derivative_matrix(ctrl.shape[1], s, order, horizon).T


def shift_matrix(n_ctrl: int, tau: float) -> np.ndarray:
    """``S`` such that ``ctrl @ S`` is the curve restricted to ``[tau, 1]``, reparameterised to ``[0, 1]``.

    Right half of de Casteljau subdivision: ``S[k, j] = b_{k-j, n-j}(tau)`` for ``k >= j``.
    The last column is ``e_n``, so the end point is kept.
    """
    S = np.zeros((n_ctrl, n_ctrl))
    if n_ctrl > _MAX_COMB:  # beyond the table of binomials: column by column
        for col in range(n_ctrl):
            S[col:, col] = bernstein_basis(n_ctrl - col, float(tau))[0]
        return S
    n = n_ctrl - 1
    powers, complements = (v[0] for v in _powers(np.array([float(tau)]), n))
    k, j, binomials = _shift_terms(n_ctrl)  # C(n-j, k-j) tau^(k-j) (1-tau)^(n-k): bernstein_basis's products
    S[k, j] = (binomials * powers[k - j]) * complements[n - k]
    return S


@lru_cache(maxsize=16)
def _shift_terms(n_ctrl: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """shift_matrix's index set-up (most of its time; a plan shifts every control step)."""
    k, j = np.tril_indices(n_ctrl)
    return k, j, _COMB[n_ctrl - 1 - j, k - j]


def convex_hull_box(ctrl: Any) -> tuple[np.ndarray, np.ndarray]:
    """Elementwise ``(min, max)`` over control points (columns); bounds the whole curve."""
    X = np.atleast_2d(np.asarray(ctrl, dtype=float))
    return X.min(axis=1), X.max(axis=1)
