"""The task-space planner's horizon from its rate bounds, in closed form: the least horizon T at which a plan of a
known shape from the measured state to the goal at rest meets every speed and acceleration bound on the
hodograph's control points; such a plan exists, so the QP over the free control points is feasible.

Per curve (degree n = M - 1), C_0 = s and C_1 = s + v0 T / n are fixed by the measured state and C_{M-3..M-1} = g
by the goal. The shapes: the m = M - 4 steps from C_1 to C_{M-3} in proportion to a profile w (even; trapezoids; a
sine arch), each w_k d with d = (g - s - v0 T / n) / sum(w). The hodograph's speeds are then
n w_k d / T (and 0 at the goal), its accelerations n (n - 1) (w_1 d - v0 T / n) / T^2 at column 0,
n (n - 1) (w_{k+1} - w_k) d / T^2 between (w_{m+1} = 0) and 0 at the goal. Each bound |alpha + beta T| <= gamma T^j
(j = 1, 2) holds for every T above the largest root of the two polynomials it is: the largest over the bounds and
curves is the horizon a shape needs, and the least over the shapes is the horizon. An even profile suits long
moves (speed-bound), the arch short ones (acceleration-bound). The result is never shorter than the least horizon
at which any plan meets the bounds (a linear program over the free control points) and close to it for long moves;
short moves get a more conservative horizon, which costs time, never feasibility."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

RAMPS = np.linspace(0.5, 3.5, 13)  # [steps] the trapezoids' ramps


@lru_cache(maxsize=8)
def _profiles(m: int) -> tuple[np.ndarray, ...]:
    """Even steps, trapezoids (steps rising over a ramp from either end) and a sine arch."""
    k = np.arange(m) + 0.5
    trapezoids = [np.minimum(1.0, np.minimum(k, m - k) / ramp) for ramp in RAMPS]
    return (np.ones(m), *trapezoids, np.sin(np.pi * k / m))


def least_horizon(start: np.ndarray, velocity: np.ndarray, goal: np.ndarray, speed, acceleration, M: int) -> float:
    """The least horizon [s] at which a plan of one of the shapes from `start` (curves,) moving at `velocity`
    (curves,) to `goal` (curves,) at rest meets |speed| <= `speed` and |acceleration| <= `acceleration` (curves,)
    at every hodograph control point (0 when any T does; inf when none does): per shape, the largest root."""
    shapes = (_terms(w, start, velocity, goal, speed, acceleration, M) for w in _profiles(M - 4))
    roots = ([(_linear if j == 1 else _quadratic)(a, b, g) for a, b, g, j in bounds] for bounds in shapes)
    return min(float(np.max(np.concatenate(r), initial=0.0)) for r in roots)


def meets(T: float, start: np.ndarray, velocity: np.ndarray, goal: np.ndarray, speed, acceleration, M: int) -> bool:
    """Whether a plan of one of the shapes over horizon `T` meets every bound."""
    shapes = (_terms(w, start, velocity, goal, speed, acceleration, M) for w in _profiles(M - 4))
    return any(all(np.all(np.abs(a + b * T) <= g * T**j + 1e-12) for a, b, g, j in bounds) for bounds in shapes)


def _terms(w: np.ndarray, start, velocity, goal, speed, acceleration, M: int):
    """The bounds per curve as (alpha, beta, gamma, j), each |alpha + beta T| <= gamma T^j with d = alpha + beta T
    scaled: speed n max(w) d (j = 1), acceleration between n (n - 1) max|dw| d and at column 0
    n (n - 1) (w_1 d - v0 T / n) (j = 2)."""
    n, W = M - 1, w.sum()
    d0, d1 = (goal - start) / W, -velocity / (n * W)  # d = d0 + d1 T
    steps = np.abs(np.diff(np.r_[w, 0.0])).max()
    return (
        (n * w.max() * d0, n * w.max() * d1, speed, 1),
        (n * (n - 1) * steps * d0, n * (n - 1) * steps * d1, acceleration, 2),
        (n * (n - 1) * w[0] * d0, n * (n - 1) * (w[0] * d1 - velocity / n), acceleration, 2),
    )


def _linear(alpha: np.ndarray, beta: np.ndarray, gamma) -> np.ndarray:
    """Per curve, the least T >= 0 above which |alpha + beta T| <= gamma T holds (inf: never, |beta| >= gamma)."""
    gamma = np.broadcast_to(gamma, alpha.shape)
    out = np.full(alpha.shape, np.inf)
    ok = gamma - np.abs(beta) > 0.0
    # (gamma - beta) T >= alpha and (gamma + beta) T >= -alpha
    out[ok] = np.maximum(alpha[ok] / (gamma[ok] - beta[ok]), -alpha[ok] / (gamma[ok] + beta[ok]))
    return np.maximum(out, 0.0)


def _quadratic(alpha: np.ndarray, beta: np.ndarray, gamma) -> np.ndarray:
    """Per curve, the largest root of gamma T^2 -+ (alpha + beta T) (0 if none): |alpha + beta T| <= gamma T^2 above."""
    gamma = np.broadcast_to(gamma, alpha.shape)
    out = np.zeros(alpha.shape)
    for sign in (1.0, -1.0):  # gamma T^2 - sign beta T - sign alpha >= 0
        b, c = -sign * beta, -sign * alpha
        disc = b * b - 4.0 * gamma * c
        real = disc >= 0.0
        out[real] = np.maximum(out[real], (-b[real] + np.sqrt(disc[real])) / (2.0 * gamma[real]))
    return out


def retimed(C: np.ndarray, velocity: np.ndarray, speed, acceleration) -> float:
    """The least horizon [s] over which the curves with control points `C` (curves, M) meet |speed| <= `speed`
    and |acceleration| <= `acceleration` (curves,) at every hodograph control point, their second control point
    moved to C_0 + `velocity` T / n as the SQP fixes it (the start velocity kept): the same path, re-timed
    uniformly (inf when the start velocity itself is above its bound)."""
    n = C.shape[1] - 1
    alpha, beta = C.copy(), np.zeros_like(C)
    alpha[:, 1], beta[:, 1] = C[:, 0], velocity / n  # P_k = alpha_k + beta_k T
    d1a, d1b = n * np.diff(alpha, axis=1), n * np.diff(beta, axis=1)
    d2a, d2b = (n - 1) * np.diff(d1a, axis=1), (n - 1) * np.diff(d1b, axis=1)
    speeds = _linear(d1a, d1b, np.asarray(speed, dtype=float)[:, None])  # each curve's bound on its columns
    accelerations = _quadratic(d2a, d2b, np.asarray(acceleration, dtype=float)[:, None])
    return float(max(speeds.max(initial=0.0), accelerations.max(initial=0.0)))
