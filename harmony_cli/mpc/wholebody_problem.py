"""The whole-body MPC's optimisation problem (MPC-W), one spec for either transcription, as CasADi SX expressions
(the robot's kinematics from OpTaS): hand pose tracking at K knots, posture and smoothness regularisers, obstacle
clearance (hard rows or a soft cost) and, with admittance, a compliant offset per hand along its pad normal.

OpTaS's OptimizationBuilder.build() is not used: it derives the Jacobian and Hessian of the whole cost, which
harmony never evaluates (its solvers differentiate the knot structure, mpc/knot_derivatives.py), and that took
most of a run's set-up (2.5 s of ~7 s warm). The symbols are the ones the builder made (same names, shapes, order)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from harmony_cli.mpc.clearance import Clearance, arm_rows, clearance_function, clearance_margins
from harmony_cli.mpc.far_rows import FarRows
from harmony_cli.mpc.knot_params import STANCE_ROWS, KnotLayout
from harmony_cli.mpc.problem import Problem, dense, linear_rows
from harmony_cli.mpc.transcription import Transcription
from harmony_cli.robot.model import Robot

STANCE_ARM = 0.5  # [m] a lever arm that makes the base's yaw error a distance, commensurate with its position's
STANCE_RESIDUALS = 3  # the last rows of the task residual: the base's x, y and yaw from its stance

if TYPE_CHECKING:
    from harmony_cli.scenario.models import AdmittanceSpec, Weights


def task_residual_function(
    robot: Robot,
    weights: Weights,
    n_knots: int,
    clearances: tuple[Clearance, ...] = (),
    footprint: tuple[tuple[float, float, float], ...] = (),
    soft: bool = False,
    compliant: bool = False,
    n_chest: int = 0,
) -> cs.Function:
    """Weighted per-knot residual r(q, ref) = sqrt(m) [sqrt(w_p/K)(p - p_ref - dp n); sqrt(w_o/K) vec(R - R_ref)]
    per hand, with the knot's task weight multiplier m (a parameter: 1 unless a late phase presses its goal), then
    if `soft`, sqrt(w_c/K) max(0, -margin) for every clearance margin (squared in the cost: C1), then the base's
    stance: sqrt(w_s/K) w_k [x - x_ref; y - y_ref; 2 STANCE_ARM sin((yaw - yaw_ref) / 2)] with the
    knot's stance weight w_k (a parameter: 0 where there is no stance to keep; the yaw's error wraps).

    q = [joints; dp per hand if compliant]: dp is the compliant offset along the pad normal n = R e_z.
    ref: see knot_params.KnotLayout. ||R - R_ref||_F^2 = 2(3 - tr(R_ref^T R)) is sign-safe.
    """
    layout = KnotLayout(len(robot.end_effectors), len(clearances), compliant, n_chest)
    nd = robot.n_dof
    q = cs.SX.sym("q", nd + (layout.n_hands if compliant else 0))
    ref = cs.SX.sym("ref", layout.rows)
    wp, wo = np.sqrt(weights.position / n_knots), np.sqrt(weights.orientation / n_knots)
    parts = []
    scale = cs.sqrt(ref[layout.task_weight])
    for h in range(layout.n_hands):
        p, R = robot.hand_pose(h, q[:nd])
        if compliant:
            p = p - R[:, 2] * q[nd + h]
        parts += [
            scale * wp * (p - ref[layout.hand_position(h)]),
            scale * wo * (cs.vec(R) - ref[layout.hand_rotation(h)]),
        ]
    if soft:
        wc = np.sqrt(weights.clearance / n_knots)
        parts += [wc * cs.fmax(0, -m) for m in clearance_margins(robot, q[:nd], ref, layout, clearances, footprint)]
    stance = ref[layout.stance_start : layout.stance_start + STANCE_ROWS]
    x, y, yaw = (q[i] for i in robot.base_joints)
    ws = np.sqrt(weights.stance / n_knots) * stance[3]
    parts += [ws * (x - stance[0]), ws * (y - stance[1]), ws * 2 * STANCE_ARM * cs.sin(0.5 * (yaw - stance[2]))]
    return cs.Function("task_residual", [q, ref], [cs.vertcat(*parts)])


def linear_residuals(
    robot: Robot,
    knots: tuple,
    ref,
    layout: KnotLayout,
    weights: Weights,
    chest_joints: list[str],
    mirrored_joints: list[tuple[str, str]],
    admittance: AdmittanceSpec | None,
) -> dict:
    """The residuals affine in (x, p), by name: chest yaw, arm symmetry, posture, joint velocity and
    acceleration and, with admittance, F_hat = F_meas + m dp'' + D dp' + K dp -> F_ref at every knot."""
    q, dq, ddq = knots
    K, nd = q.shape[1], robot.n_dof
    moving = [i for i in range(robot.n_dof) if i not in robot.pinned_joints]
    chest = [robot.index(j) for j in chest_joints]
    arms = [i for i in moving if i not in robot.base_joints and i not in chest]
    home = robot.home[arms][:, None]
    linear = {
        "chest_yaw": np.sqrt(weights.chest_yaw / K) * (q[chest, :] - ref[layout.chest_ref, :]),
        "arm_symmetry": np.sqrt(weights.arm_symmetry / K)
        * cs.vertcat(cs.SX(0, K), *[q[robot.index(a), :] + q[robot.index(b), :] for a, b in mirrored_joints]),
        "posture": np.sqrt(weights.posture / K) * (q[arms, :] - home),
        "velocity": np.sqrt(weights.velocity / K) * dq[moving, :],
        "acceleration": np.sqrt(weights.acceleration / ddq.shape[1]) * ddq[moving, :],
    }
    if admittance is not None:
        ddq_k = ddq if ddq.shape[1] == K else cs.horzcat(ddq, ddq[:, -1])  # traditional: K - 1 differences
        w = np.sqrt(admittance.weight / K)
        for h, hand in enumerate(robot.hand_names):
            f_hat = (
                ref[layout.force_meas(h), :]
                + admittance.mass * ddq_k[nd + h, :]
                + admittance.damping_value * dq[nd + h, :]
                + admittance.stiffness * q[nd + h, :]
            )
            linear[f"admittance_{hand}"] = w * (f_hat - ref[layout.force_ref(h), :])
    return {name: r for name, r in linear.items() if r.numel() > 0}  # e.g. a robot without a chest joint


def _affine_form(linear: dict, x, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(L, S, c) with vec(residuals) = L x + S p + c; raises if they are not affine."""
    r_lin = cs.vertcat(*[cs.vec(r) for r in linear.values()])
    if not cs.is_linear(r_lin, cs.vertcat(x, p)):
        raise ValueError("the linear cost residuals are not affine in the decision variables and parameters")
    L, S, c = (
        dense(v)
        for v in cs.Function("lin", [x, p], [cs.jacobian(r_lin, x), cs.jacobian(r_lin, p), r_lin])(
            np.zeros(x.numel()), np.zeros(p.numel())
        )
    )
    return L, S, c.ravel()


def build_problem(
    robot: Robot,
    transcription: Transcription,
    weights: Weights,
    chest_joints: list[str],
    mirrored_joints: list[tuple[str, str]],
    clearances: tuple[Clearance, ...] = (),
    footprint: tuple = (),
    clearance: str = "hard",
    admittance: AdmittanceSpec | None = None,
) -> Problem:
    """The MPC-W problem. Clearance is `hard` (rows h(q_k) >= 0 at knots k >= 1) or `soft` (a squared-hinge cost
    term). With `admittance`, the transcription carries one compliant offset per hand after the joints (see
    task_residual_function)."""
    K = transcription.n_knots
    layout = KnotLayout(len(robot.end_effectors), len(clearances), admittance is not None, len(chest_joints))
    parts = [cs.SX.sym(name, *shape) for name, shape in transcription.variable_shapes.items()]
    x = cs.vertcat(*[cs.vec(v) for v in parts])
    ref = cs.SX.sym("knot_params", layout.rows, K)
    knots = transcription.knots(x)
    soft = clearance == "soft" and bool(clearances)
    task_residual = task_residual_function(
        robot, weights, K, clearances, footprint, soft, layout.compliant, layout.n_chest
    )
    residual = task_residual.map(K)(knots[0], ref)
    terms: dict[str, cs.SX] = {}
    for h, hand in enumerate(robot.hand_names):
        terms[f"position_{hand}"] = cs.sumsqr(residual[layout.hand_position(h), :])
        terms[f"orientation_{hand}"] = cs.sumsqr(residual[layout.hand_rotation(h), :])
    if soft:
        terms["clearance"] = cs.sumsqr(residual[layout.hands_end : -STANCE_RESIDUALS, :])
    terms["stance"] = cs.sumsqr(residual[-STANCE_RESIDUALS:, :])
    linear = linear_residuals(robot, knots, ref, layout, weights, chest_joints, mirrored_joints, admittance)
    terms |= {name: cs.sumsqr(r) for name, r in linear.items()}
    constraint = (
        clearance_function(robot, clearances, footprint, layout.compliant, layout.n_chest)
        if clearances and not soft
        else None
    )
    p = cs.vec(ref)
    L, S, c = _affine_form(linear, x, p)
    rows = transcription.linear_constraints(x, joint_limits(robot, admittance)[2])
    A, lb, ub = linear_rows(x, rows | transcription.coupling_rows(x, robot.couplings))
    return Problem(
        x=x,
        p=p,
        terms=terms,
        A=A,
        lb=lb,
        ub=ub,
        task_residual=task_residual,
        position_basis=transcription.position_basis,
        ref_shape=(ref.shape[0], K),
        L=L,
        c=c,
        S=S,
        constraint=constraint if constraint is not None and constraint.numel_out(0) else None,
        reverse_rows=arm_rows(robot, clearances) if constraint is not None else 0,
        far=far_rows(robot, clearances, layout, constraint),
    )


def far_rows(
    robot: Robot, clearances: tuple[Clearance, ...], layout: KnotLayout, constraint: cs.Function | None
) -> FarRows | None:
    """The arms' clearance rows (the constraint's last, clearance.arm_rows) as FarRows (None: no such rows): the
    arms' lever bounds over the constraint's q (the joints, then any compliant offsets, which move no arm point)
    and each row's body in the knot parameters."""
    if constraint is None or not arm_rows(robot, clearances):
        return None
    n_q = constraint.size1_in(0)
    levers = np.zeros(n_q)
    for chain in robot.arms:
        for name, lever in chain.levers:
            levers[robot.index(name)] = max(levers[robot.index(name)], lever)
    arms = sum(chain.n_points > 0 for chain in robot.arms)
    bodies = [o for o, c in enumerate(clearances) if c.arm is not None for _ in range(arms)]
    centre = [range(layout.obstacle_centre(o).start, layout.obstacle_centre(o).stop) for o in bodies]
    poses = np.array([[*c, layout.obstacle_yaw(o)] for c, o in zip(centre, bodies)], dtype=int)
    return FarRows(levers, poses)


def joint_limits(robot: Robot, admittance: AdmittanceSpec | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lower, upper, velocity limit) of the MPC's q: the joints, then the compliant offsets if any."""
    n = len(robot.end_effectors) if admittance is not None else 0
    offset, rate = (admittance.max_offset, admittance.max_offset_rate) if admittance is not None else (0.0, 0.0)
    return (
        np.r_[robot.lower, np.full(n, -offset)],
        np.r_[robot.upper, np.full(n, offset)],
        np.r_[robot.velocity_limit, np.full(n, rate)],
    )
