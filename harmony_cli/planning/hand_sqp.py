"""The task-space planner's SQP: Gauss-Newton over the free Bezier control points of both hands' positions and
their common heading, a (7, M) array, one dense QP (DAQP by default) per iteration.

The hands stay level with their pads facing each other by construction, R_h(t) = Rz(psi(t)) R_h(home) (an SO(2)
curve: no quaternion to normalise). Costs keep the inter-hand vector across the heading, both hands at one height
and at the goal's distance apart, and smooth the control points. Start: control points 0 and 1 from the measured
positions and velocities; end: the last three at the goal (at rest). Speed and acceleration bounds on the
hodograph control points. Obstacles: the signed distance of each hand (and, while carrying, of the object between
them) at sample times stays above its clearance, linearised at the current plan, where the obstacle is at that
time, each obstacle and point's rows lifted by a slack >= 0 that costs SLACK_COST per metre (an exact L1 penalty):
every QP is feasible, and a plan short of a clearance says by how much. Hands below the arms' reach with the pads
level (robot/reach.py): a bound on the z control points. The base follows the hands: soft rows keep its
footprint, carried behind the hands as at home, clear of the obstacles and table legs (plan_base.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from harmony_cli.maths.bezier import bernstein_basis, difference_matrix
from harmony_cli.mpc.codegen import Buffered
from harmony_cli.mpc.distance_code import CompiledDistance
from harmony_cli.planning.footprint_code import CompiledMargins
from harmony_cli.planning.hand_plan import ROWS, Ends, Obstacle, Outcome, Solved
from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.planning.plan_seed import fix_ends

if TYPE_CHECKING:
    from harmony_cli.scenario.models import PlannerSpec

SLACK_COST = 1e3  # per metre of an obstacle's clearance shortfall (the QP's linear cost on its slack)
SLACK_RIDGE = 1e-6  # the slacks' own curvature, keeping the QP strictly convex (DAQP)


class HandSQP:
    """Built once for a set of obstacles; `solve` runs the SQP from given control points. `reliefs` (per obstacle,
    [m]): how far its clearance is lowered (the planner sets them to the goal's, goal_reliefs)."""

    def __init__(
        self,
        spec: PlannerSpec,
        obstacles: list[Obstacle],
        heading_offset: float,
        base: PlannedBase | None = None,
        ceiling: float | None = None,
    ):
        self.spec, self.obstacles = spec, obstacles
        self.base, self.ceiling = base, np.inf if ceiling is None else ceiling  # [m] the hands' highest (reach.py)
        # the pads face along h(heading + this): 0 when home faces +x, the home's own yaw when it does not
        self.facing_shift = np.pi / 2 - heading_offset
        M = self.M = spec.control_points
        self.free = np.zeros((ROWS, M), dtype=bool)
        self.free[:, 2 : M - 3] = True
        self.n_free = int(self.free.sum())
        s = self.s = np.linspace(0.0, 1.0, spec.samples + 1)[1:]  # obstacle and facing samples (s = 0 is fixed)
        self.B = bernstein_basis(M, s)  # (S, M)
        # a route's least-squares fit of a shift at the samples (plan_seed.moved_onto): in the step, one product
        self.fit = np.linalg.pinv(self.B[:, self.free[0]])
        self._s_start = np.r_[0.0, s]
        self._B_start = bernstein_basis(M, self._s_start)  # the start too (the base's reliefs)
        D1, D2 = difference_matrix(M, 1), difference_matrix(M, 2)
        eye = np.eye(ROWS)
        w = spec.weights
        # linear residuals: smoothness (first and second differences of every curve) and level hands
        level = np.zeros((M, ROWS * M))
        level[:, 2 * M : 3 * M], level[:, 5 * M : 6 * M] = np.eye(M), -np.eye(M)
        self.J_lin = np.vstack([w.smoothness * np.kron(eye, D1), w.acceleration * np.kron(eye, D2), w.level * level])
        # bound rows: hodograph control points of velocity and acceleration, per curve (bounds scale with T)
        self.A = np.vstack([np.kron(eye, D1), np.kron(eye, D2)])
        self.keep = np.any(self.A[:, self.free.ravel()] != 0, axis=1)  # rows with a free variable
        n1, n2 = self._differences = D1.shape[0], D2.shape[0]
        self.set_bounds(*rate_bounds(spec))
        self._rate_order = np.r_[np.ones(ROWS * n1), 2 * np.ones(ROWS * n2)][self.keep]
        # the speed rows' curve and hodograph column, and each curve's first (fixed) hodograph point: the brake
        columns = np.r_[np.tile(np.arange(n1), ROWS), -np.ones(ROWS * n2, dtype=int)][self.keep]
        self._speed_rows = np.flatnonzero(columns >= 0)
        self._speed_curve = (np.flatnonzero(self.keep)[self._speed_rows] // n1).astype(int)
        self._speed_column = columns[self._speed_rows]
        self._first_speed = np.arange(ROWS) * n1
        self.n_keep, self.n_lin = int(self.keep.sum()), self.J_lin.shape[0]
        self.n_points = 3  # hand 0, hand 1, the carried object (midpoint)
        n_rows = self.n_keep + len(obstacles) * self.n_points * s.size
        # the free control points, then a slack per obstacle and point (hand 0, hand 1, the carried object)
        self.n_vars = self.n_free + len(obstacles) * self.n_points
        dense = {"h": cs.Sparsity.dense(self.n_vars, self.n_vars), "a": cs.Sparsity.dense(n_rows, self.n_vars)}
        self.qp = Buffered(cs.conic("planner", spec.qp, dense, {"error_on_fail": False}))
        self._distances = [CompiledDistance(o.shape, self.n_points * s.size) for o in obstacles]  # hands, object
        self._base_nearest = None if base is None else CompiledMargins(base, self._s_start.size)
        self._points = np.zeros((self.n_points * s.size, 3))  # their points, per obstacle
        self.reliefs = np.zeros(len(obstacles))
        self._bind_buffers()

    def set_bounds(self, speeds: np.ndarray, accelerations: np.ndarray) -> None:
        """The speed and acceleration bounds per curve (7,) of the plans from now on (a held box's, grip_force.py): a
        plan that cannot meet them by its end takes the closed-form horizon (hand_mpc.py)."""
        n1, n2 = self._differences
        self._rate_limits = np.r_[np.repeat(speeds, n1), np.repeat(accelerations, n2)][self.keep]
        self.speeds, self.accelerations = speeds, np.asarray(accelerations, dtype=float)

    @property
    def path(self) -> str:
        """How it solves (meta.json, before the loop): loads the compiled distances (gcc on a cold cache) there."""
        code = sorted({c.code_path() for c in [*self._distances, self._base_nearest] if c is not None}) or ["none"]
        return f"Gauss-Newton SQP on the control points, {self.spec.qp} QP, numpy derivatives, distances: {code[0]}"

    def _bind_buffers(self) -> None:
        """What each step writes in place (no per-step allocation or copy): the Jacobian over the free control points
        and the QP's inputs (Buffered's, column-major), their free columns viewed as (curve, column, row)."""
        free, S, n_lin, args = self.free.ravel(), self.s.size, self.n_lin, self.qp.args
        self.B_free = self.B[:, self.free[0]].T.copy()  # (free columns, S)
        self._B_hands = np.tile(self.B_free, 2)  # both hands' samples side by side
        self._hand_weights = np.repeat(np.eye(2), S, axis=1)  # a hand's gradient: 1 in its own curves' rows, 0 else
        n_rows = n_lin + 2 * S
        self._J = np.zeros((n_rows, self.n_free), order="F")  # vstack(...)[:, free]'s layout: same BLAS sums
        self._J[:n_lin] = self.J_lin[:, free]
        columns = self._J.T.reshape(ROWS, -1, n_rows)
        self._J_face, self._J_width = columns[:, :, n_lin : n_lin + S], columns[:, :, n_lin + S : n_lin + 2 * S]
        self._r, self._ridge = np.zeros(n_rows), 1e-9 * np.eye(self.n_free)
        self._heights = np.isin(np.nonzero(self.free)[0], (2, 5))  # the hands' z among the free variables
        self._height_index = np.flatnonzero(free)[self._heights]  # and in C.ravel()
        H, qp_columns = args["h"].reshape(self.n_vars, self.n_vars), args["a"].reshape(self.n_vars, -1)
        self._H = H[: self.n_free, : self.n_free]
        qp_columns[: self.n_free].T[: self.n_keep] = self.A[self.keep][:, free]
        self._qp_rows = qp_columns[: self.n_free].reshape(ROWS, -1, qp_columns.shape[1])
        # a slack lifts each clearance row of its obstacle and point: every QP is feasible, a shortfall costs
        # SLACK_COST per metre (an exact penalty: none is taken where the rows can be met), and one point's start
        # inside a margin does not excuse another's
        for k in range(len(self.obstacles) * self.n_points):
            qp_columns[self.n_free + k, self.n_keep + k * S : self.n_keep + (k + 1) * S] = 1.0
            H[self.n_free + k, self.n_free + k] = SLACK_RIDGE
        args["g"][self.n_free :] = SLACK_COST
        args["uba"][self.n_keep :], args["lbx"][:], args["ubx"][:] = np.inf, -np.inf, np.inf
        args["lbx"][self.n_free :] = 0.0

    def solve(self, C, t: float, T: float, ends: Ends, iterations: int, carried, width) -> Solved:
        """Gauss-Newton SQP from `C` (changed in place) towards `ends` = (state, goal, goal heading) over [t, t + T]:
        `iterations` QPs at most, fewer when a step is below the tolerance."""
        fix_ends(C, *ends, T)
        outcome, it, shortfall, clearance, base_clearance = Outcome.STEPPED, 0, 0.0, np.inf, np.inf
        while it < iterations:
            it += 1
            step, clearance, base_clearance, shortfall = self._sqp_step(C, t, T, carried, width)
            if step is None:
                outcome = Outcome.FAILED
                break
            C[self.free] += step
            if np.abs(step).max() < self.spec.tol:
                outcome = Outcome.CONVERGED
                break
        return Solved(C, T, outcome, it, clearance, shortfall, base_clearance)

    def _sqp_step(self, C: np.ndarray, t: float, T: float, carried, width: float):
        """One Gauss-Newton QP over the free control points of the plan over [t, t + T] and the obstacles' slacks:
        (step or None when the QP fails, predicted clearance, the base footprint's predicted margin, the largest
        slack taken [m])."""
        x, args = C.ravel(), self.qp.args
        curves = C @ self.B.T  # (7, S)
        self._pose_residuals(curves, width)
        self._r[: self.n_lin] = self.J_lin @ x
        np.add(self._J.T @ self._J, self._ridge, out=self._H)
        args["g"][: self.n_free] = self._J.T @ self._r
        base_clearance = np.inf
        if self.base is not None:  # its active rows only (usually none): the same sums as zero rows in J, less work
            with_start = C @ self._B_start.T  # its fixed start (s = 0), then the samples
            r, J, base_clearance = self.base.rows(
                with_start, t + T * self._s_start, self.spec.weights.base, self.B_free, self._base_nearest
            )
            if len(r):
                self._H += J.T @ J
                args["g"][: self.n_free] += J.T @ r
        limit = self._rate_limits * T**self._rate_order  # D^k P are s-derivatives: time derivative = D^k P / T^k
        hodographs = self.A @ x  # every curve's velocity and acceleration control points (s-units)
        Ax = hodographs[self.keep]
        # the speed rows raised to what braking from each curve's start speed at the acceleration bound leaves there:
        # bounds that tighten below the hands' speed (a slower carry) slow the plan as fast as they allow, QP feasible
        start, curve = np.abs(hodographs[self._first_speed]), self._speed_curve
        brake = start[curve] - self._speed_column * self.accelerations[curve] * T**2 / (self.M - 2)
        np.maximum(limit[self._speed_rows], brake, out=brake)
        limit[self._speed_rows] = brake
        args["lba"][: self.n_keep], args["uba"][: self.n_keep] = -limit - Ax, limit - Ax
        clearance = self._clearance_rows(curves, t, T, carried)
        # the hands' heights: each curve lies in its control points' hull
        args["ubx"][: self.n_free][self._heights] = self.ceiling - x[self._height_index]
        out = self.qp()
        if not self.qp.stats()["success"]:
            return None, clearance, base_clearance, np.inf
        shortfall = float(out["x"][self.n_free :].max(initial=0.0))
        return out["x"][: self.n_free].copy(), clearance, base_clearance, shortfall

    def _pose_residuals(self, curves: np.ndarray, width: float) -> None:
        """Residuals at the samples and their Jacobians (free columns), into the rows after the linear ones: facing
        (p_1 - p_0) . h(psi + facing_shift), h = (cos, sin, 0), then grip width |p_1 - p_0| - the goal's (a held
        box is not stretched). A row is weight (curves, 1, S) * basis (free columns, S)."""
        S, B, r = self.s.size, self.B_free, self._r[self.n_lin :]
        d, psi, w = curves[3:5] - curves[0:2], curves[6] + self.facing_shift, self.spec.weights.facing
        cos, sin = h = np.array([np.cos(psi), np.sin(psi)])
        r[:S] = w * (d[0] * cos + d[1] * sin)
        self._J_face[0:2] = (-w * h)[:, None] * B
        self._J_face[3:5] = (w * h)[:, None] * B
        self._J_face[6] = w * (d[0] * -sin + d[1] * cos) * B
        across = curves[3:6] - curves[0:3]
        length = np.maximum(np.sqrt(np.add.reduce(across * across, axis=0)), 1e-9)  # np.linalg.norm's own sum
        w = self.spec.weights.width
        r[S : 2 * S] = w * (length - width)
        unit = across / length
        self._J_width[0:3] = (-w * unit)[:, None] * B
        self._J_width[3:6] = (w * unit)[:, None] * B

    def _clearance_rows(self, curves: np.ndarray, t: float, T: float, carried: tuple[float, float] | None) -> float:
        """The QP's linearised clearance rows and lower bounds, per obstacle S each for hand 0, hand 1 and the object
        (inactive while not carrying); returns the smallest predicted clearance margin."""
        n, lba, margins, points = self.s.size, self.qp.args["lba"], [np.inf], self._points
        hands = curves[0:6].reshape(2, 3, n).transpose(0, 2, 1)  # (hand, sample, xyz)
        object_point = 0.5 * (curves[0:3] + curves[3:6]).T - [0.0, 0.0, carried[1] if carried else 0.0]
        for i, (obstacle, shape) in enumerate(zip(self.obstacles, self._distances)):
            # a moving obstacle at each sample time: the points relative to it, as if it stood at shape.centre
            moved = 0.0 if obstacle.motion is None else obstacle.motion(t + T * self.s) - obstacle.shape.centre
            first = self.n_keep + i * self.n_points * n
            points[: 2 * n] = (hands - moved).reshape(-1, 3)
            points[2 * n :] = object_point - moved  # against the shape grown by the object's half diagonal
            shape.grow[2 * n :] = carried[0] if carried else 0.0
            every, gradients = shape.distance(points)
            dist, grad = every[: 2 * n], gradients[: 2 * n]
            rows = self._qp_rows[:, :, first : first + 2 * n]
            rows[0:3], rows[3:6] = (self._hand_weights[:, None] * grad.T)[:, :, None] * self._B_hands
            need = obstacle.clearance - self.reliefs[i]  # lowered where the goal itself is within it
            lba[first : first + 2 * n] = need - dist
            margins += map(float, (dist - need).reshape(2, n).min(axis=1))
            rows, bounds = self._qp_rows[:, :, first + 2 * n : first + 3 * n], lba[first + 2 * n : first + 3 * n]
            if carried is None:
                rows[:], bounds[:] = 0.0, -np.inf
                continue
            dist, grad = every[2 * n :], gradients[2 * n :]
            rows[0:3] = rows[3:6] = (0.5 * grad.T)[:, None] * self.B_free
            bounds[:] = need - dist
            margins.append(float((dist - need).min()))
        return min(margins)


def rate_bounds(spec: PlannerSpec) -> tuple[np.ndarray, np.ndarray]:
    """The planner's speed and acceleration bounds per curve (both hands' x, y, z, then the heading)."""
    speeds = np.r_[spec.max_speed, spec.max_speed, spec.max_yaw_rate]
    return speeds, np.r_[spec.max_acceleration, spec.max_acceleration, spec.max_yaw_acceleration]
