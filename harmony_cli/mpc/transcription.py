"""The only thing Table 1 changes: how a joint trajectory over the horizon becomes decision variables.

Both transcriptions expose the same view of the trajectory (q, q_dot, q_ddot at K equidistant knots), so
the whole-body MPC states its costs once. Vectors are column-major: x = [vec(positions); vec(velocities)].
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import casadi as cs
import numpy as np

from harmony_cli.maths import bezier

if TYPE_CHECKING:
    from collections.abc import Sequence

    from harmony_cli.robot.mimic import Coupling
    from harmony_cli.scenario.models import MpcSpec


class Transcription(Protocol):
    """How a joint trajectory over the horizon becomes the decision vector x: the MPC states its costs on
    `knots(x)` and reads its command out with `readout`; `shift` warm-starts the next solve."""

    name: str
    n_dof: int
    n_knots: int
    horizon: float
    n_vars: int
    knot_times: np.ndarray  # (K,) [s]
    position_basis: np.ndarray  # K x n_pos: q at the knots = positions(x) @ position_basis.T
    variable_shapes: dict[str, tuple[int, int]]  # decision variable blocks, in the order of x
    decision_label: str

    def positions(self, x): ...

    def knots(self, x) -> tuple:
        """(q, q_dot, q_ddot) at the knots, numpy or CasADi."""

    def linear_constraints(self, x, velocity_limit: np.ndarray) -> dict[str, tuple]:
        """Named rows (expr, lower, upper), affine in x."""

    def coupling_rows(self, x, couplings: Sequence[Coupling]) -> dict[str, tuple]:
        """Named equality rows (expr, offset, offset), affine in x, holding each coupling's follower at its leader's
        value times the multiplier plus the offset along the whole trajectory, its velocity too (none: {})."""

    def bounds(
        self,
        lower: np.ndarray,
        upper: np.ndarray,
        velocity_limit: np.ndarray,
        q_now: np.ndarray,
        pinned: list[int],
        q_pinned: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(lbx, ubx): limits, the measured state at t = 0 and the pinned joints."""

    def readout(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(q, q_dot) at time t into the horizon."""

    def velocity_band(self, x: np.ndarray, q_now: np.ndarray, change: float) -> tuple[slice, np.ndarray, np.ndarray]:
        """Where in x (a slice) and within which bounds (lower, upper) q_dot(0) stays within `change` of its value in
        `x` (the warm start), with q(0) = q_now."""

    def shift(self, x: np.ndarray, dt: float) -> np.ndarray:
        """x of the same trajectory started dt later (warm start)."""


def _times(X, M: np.ndarray):
    """X @ M for numpy or CasADi X."""
    return cs.mtimes(X, cs.DM(M)) if isinstance(X, (cs.SX, cs.MX, cs.DM)) else X @ M


def _reshape(x, rows: int, cols: int):
    return cs.reshape(x, rows, cols) if isinstance(x, (cs.SX, cs.MX, cs.DM)) else np.reshape(x, (rows, cols), "F")


class BezierTranscription:
    """q(t) = sum_j b_j(t/T) Q_j with N control points Q (n_dof x N); K knots independent of N."""

    name = "bezier"

    def __init__(self, n_dof: int, n_ctrl: int, n_knots: int, horizon: float):
        self.n_dof, self.n_ctrl, self.n_knots, self.horizon = n_dof, n_ctrl, n_knots, horizon
        self.knot_times = np.linspace(0.0, horizon, n_knots)
        s = self.knot_times / horizon
        self.basis = [bezier.derivative_matrix(n_ctrl, s, order, horizon) for order in range(3)]  # K x N each
        self.n_vars = n_dof * n_ctrl
        self.variable_shapes = {"Q": (n_dof, n_ctrl)}
        self.position_basis = self.basis[0]  # q_knots = Q @ position_basis.T
        self.decision_label = f"Q[0..{n_ctrl - 1}]"
        self._readout: dict[float, tuple[np.ndarray, np.ndarray]] = {}  # t -> basis rows of q(t), q_dot(t)
        self._shift: dict[float, np.ndarray] = {}  # dt -> shift_matrix

    def positions(self, x):
        return _reshape(x, self.n_dof, self.n_ctrl)

    def knots(self, x):
        """(q, q_dot, q_ddot) at the knots, each n_dof x K."""
        Q = self.positions(x)
        return tuple(_times(Q, B.T) for B in self.basis)

    def linear_constraints(self, x, velocity_limit: np.ndarray):
        """Named linear rows (expr, lower, upper): the hodograph bounds the velocity of the whole curve."""
        D = bezier.difference_matrix(self.n_ctrl, 1, self.horizon)
        rows = cs.vec(_times(self.positions(x), D.T))
        v = np.tile(velocity_limit, self.n_ctrl - 1)
        return {"velocity_hodograph": (rows, -v, v)}

    def coupling_rows(self, x, couplings: Sequence[Coupling]) -> dict[str, tuple]:
        """On every control point: the curves' partition of unity makes q_f(t) = m q_l(t) + o (and q_f' = m q_l')
        at every t."""
        if not couplings:
            return {}
        Q = self.positions(x)
        rows = cs.vertcat(*[cs.vec(Q[c.follower, :] - c.multiplier * Q[c.leader, :]) for c in couplings])
        offsets = np.repeat([c.offset for c in couplings], self.n_ctrl)
        return {"mimic_coupling": (rows, offsets, offsets)}

    def bounds(self, lower, upper, velocity_limit, q_now, pinned, q_pinned):
        lo, hi = np.tile(lower[:, None], self.n_ctrl), np.tile(upper[:, None], self.n_ctrl)
        lo[:, 0] = hi[:, 0] = q_now  # initial state from the measurement
        lo[pinned, :] = hi[pinned, :] = np.asarray(q_pinned)[:, None]
        return lo.ravel("F"), hi.ravel("F")

    def velocity_band(self, x: np.ndarray, q_now: np.ndarray, change: float) -> tuple[slice, np.ndarray, np.ndarray]:
        Q, step = self.positions(x), self.horizon / (self.n_ctrl - 1)  # q_dot(0) = (Q_1 - Q_0) / step
        centre = q_now + (Q[:, 1] - Q[:, 0])
        return slice(self.n_dof, 2 * self.n_dof), centre - step * change, centre + step * change

    def readout(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        if t not in self._readout:  # the loop reads out at the same few times every step: their bases once
            s = np.array([min(t / self.horizon, 1.0)])
            self._readout[t] = (
                bezier.derivative_matrix(self.n_ctrl, s, 0)[0],
                bezier.derivative_matrix(self.n_ctrl, s, 1, self.horizon)[0],
            )
        Q = self.positions(x)
        position, velocity = self._readout[t]
        return Q @ position, Q @ velocity

    def shift(self, x: np.ndarray, dt: float) -> np.ndarray:
        if dt not in self._shift:  # de Casteljau by one control period, the same every step
            self._shift[dt] = bezier.shift_matrix(self.n_ctrl, dt / self.horizon)
        return (self.positions(x) @ self._shift[dt]).ravel("F")


class TraditionalTranscription:
    """The paper's baseline: q_k and q_dot_k at K knots, q_{k+1} = q_k + delta q_dot_k (Euler) or trapezoidal."""

    name = "traditional"

    def __init__(self, n_dof: int, n_knots: int, horizon: float, integration: str = "euler"):
        self.n_dof, self.n_knots, self.horizon, self.integration = n_dof, n_knots, horizon, integration
        self.knot_times = np.linspace(0.0, horizon, n_knots)
        self.delta = horizon / (n_knots - 1)
        self.n_vars = 2 * n_dof * n_knots
        self.variable_shapes = {"q": (n_dof, n_knots), "dq": (n_dof, n_knots)}
        self.position_basis = np.eye(n_knots)
        self.decision_label = f"q[0..{n_knots - 1}], dq[0..{n_knots - 1}]"

    def split(self, x):
        half = self.n_dof * self.n_knots
        return _reshape(x[:half], self.n_dof, self.n_knots), _reshape(x[half:], self.n_dof, self.n_knots)

    def positions(self, x):
        return self.split(x)[0]

    def knots(self, x):
        q, dq = self.split(x)
        ddq = (dq[:, 1:] - dq[:, :-1]) / self.delta
        return q, dq, ddq

    def linear_constraints(self, x, velocity_limit: np.ndarray):
        q, dq = self.split(x)
        if self.integration == "euler":
            step = self.delta * dq[:, :-1]
        else:
            step = 0.5 * self.delta * (dq[:, :-1] + dq[:, 1:])
        rows = cs.vec(q[:, 1:] - q[:, :-1] - step)
        zero = np.zeros(self.n_dof * (self.n_knots - 1))
        return {f"{self.integration}_integration": (rows, zero, zero)}

    def coupling_rows(self, x, couplings: Sequence[Coupling]) -> dict[str, tuple]:
        """The positions at every knot, with the integration rows the velocities at all knots but one, which gets a
        row of its own: the last (Euler: no step uses its velocity) or the first (trapezoidal: the steps couple only
        the sums of neighbouring velocities). No row follows from the others: the equality rows stay independent."""
        if not couplings:
            return {}
        q, dq = self.split(x)
        knot = self.n_knots - 1 if self.integration == "euler" else 0
        rows = [q[c.follower, :].T - c.multiplier * q[c.leader, :].T for c in couplings]
        rows += [dq[c.follower, knot] - c.multiplier * dq[c.leader, knot] for c in couplings]
        offsets = np.r_[np.repeat([c.offset for c in couplings], self.n_knots), np.zeros(len(couplings))]
        return {"mimic_coupling": (cs.vertcat(*rows), offsets, offsets)}

    def bounds(self, lower, upper, velocity_limit, q_now, pinned, q_pinned):
        K = self.n_knots
        qlo, qhi = np.tile(lower[:, None], K), np.tile(upper[:, None], K)
        vlo, vhi = np.tile(-velocity_limit[:, None], K), np.tile(velocity_limit[:, None], K)
        qlo[:, 0] = qhi[:, 0] = q_now
        qlo[pinned, :] = qhi[pinned, :] = np.asarray(q_pinned)[:, None]
        vlo[pinned, :] = vhi[pinned, :] = 0.0
        return np.concatenate([qlo.ravel("F"), vlo.ravel("F")]), np.concatenate([qhi.ravel("F"), vhi.ravel("F")])

    def velocity_band(self, x: np.ndarray, q_now: np.ndarray, change: float) -> tuple[slice, np.ndarray, np.ndarray]:
        start = self.n_dof * self.n_knots  # dq[:, 0]
        dq0 = self.split(x)[1][:, 0]
        return slice(start, start + self.n_dof), dq0 - change, dq0 + change

    def readout(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State at time t <= delta along the transcription's own interpolation of the first interval."""
        q, dq = self.split(x)
        if self.integration == "euler":  # velocity constant over the interval
            return q[:, 0] + t * dq[:, 0], dq[:, 0].copy()
        slope = (dq[:, 1] - dq[:, 0]) / self.delta
        return q[:, 0] + t * dq[:, 0] + 0.5 * t * t * slope, dq[:, 0] + t * slope

    def shift(self, x: np.ndarray, dt: float) -> np.ndarray:
        """Linear interpolation of the knot trajectory at t_k + dt (held constant past the horizon)."""
        q, dq = self.split(x)
        t = np.minimum(self.knot_times + dt, self.horizon)
        interp = lambda X: np.stack([np.interp(t, self.knot_times, row) for row in X])
        return np.concatenate([interp(q).ravel("F"), interp(dq).ravel("F")])


def make_transcription(mpc: MpcSpec, n_dof: int) -> Transcription:
    if mpc.transcription == "bezier":
        return BezierTranscription(n_dof, mpc.control_points, mpc.knots, mpc.horizon)
    return TraditionalTranscription(n_dof, mpc.knots, mpc.horizon, mpc.integration)
