"""Whole-body MPC (MPC-W): track both hands' poses at K knots with all joints, built once, warm-started."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as cs
import numpy as np
import optas

from harmony_cli.geometry import symbolic_distance
from harmony_cli.robot import Robot
from harmony_cli.solvers import Problem, SolveResult, linear_rows, make_solver
from harmony_cli.transcription import make_transcription
from harmony_cli.world import obstacle_shape, table_legs
from harmony_cli.wrench import LowPass


@dataclass(frozen=True)
class Command:
    q: np.ndarray  # position targets at t + control_dt
    qd: np.ndarray  # velocity targets (base: mean velocity over the control period)
    held: bool  # True when the solve failed and the last good plan was used
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))  # compliant offsets at t + control_dt [m]


@dataclass(frozen=True)
class Clearance:
    """An obstacle as the whole-body MPC sees it: its centre (3) and yaw are parameters at every knot (so it
    may move); the base footprint circles keep `base` [m] from it in x, y and the hands `hand` [m] in 3-D
    (None: the hands may touch it, e.g. a table)."""

    kind: str
    half: np.ndarray
    base: float
    hand: float | None


SOFTMIN = 0.01  # [m] smoothing of the footprint's min over circles; the soft-min is below the min by <= this * ln n


def clearance_margins(robot: Robot, q, obstacle_poses, clearances: tuple[Clearance, ...],
                      footprint: tuple[tuple[float, float, float], ...]) -> list:
    """Clearance margins (>= 0: clear) of a configuration q: per obstacle, the base footprint (a smooth soft-min
    over its circles, a lower bound of their minimum; planar) if there is a footprint, then each hand (3-D) if
    the obstacle keeps hands away. obstacle_poses stacks [centre (3); yaw] per obstacle."""
    hands = [robot.hand_pose(h, q)[0] for h in range(len(robot.end_effectors))]
    bx, by, byaw = (q[i] for i in robot.base_joints)
    circles = [(cs.vertcat(bx + cs.cos(byaw) * x - cs.sin(byaw) * y, by + cs.sin(byaw) * x + cs.cos(byaw) * y, 0),
                r) for x, y, r in footprint]
    margins = []
    for o, obstacle in enumerate(clearances):
        centre, yaw = obstacle_poses[4 * o: 4 * o + 3], obstacle_poses[4 * o + 3]
        if circles:
            m = cs.vertcat(*[symbolic_distance(obstacle.kind, obstacle.half, centre, yaw, point, planar=True)
                             - obstacle.base - radius for point, radius in circles])
            low = cs.mmin(m)  # shifted log-sum-exp: exact, smooth, no overflow
            margins.append(low - SOFTMIN * cs.log(cs.sum1(cs.exp(-(m - low) / SOFTMIN))))
        if obstacle.hand is not None:
            margins += [symbolic_distance(obstacle.kind, obstacle.half, centre, yaw, p) - obstacle.hand for p in hands]
    return margins


def clearance_function(robot: Robot, clearances: tuple[Clearance, ...], footprint: tuple,
                       compliant: bool = False) -> cs.Function:
    """h(q, ref) >= 0 per knot (q, ref as in task_residual_function): the hard clearance constraints."""
    H, nd = len(robot.end_effectors), robot.n_dof
    q = cs.SX.sym("q", nd + (H if compliant else 0))
    ref = cs.SX.sym("ref", knot_param_rows(H, len(clearances), compliant))
    return cs.Function("clearance", [q, ref], [cs.vertcat(*clearance_margins(robot, q[:nd], ref[12 * H:],
                                                                              clearances, footprint))])


def knot_param_rows(n_hands: int, n_obstacles: int, compliant: bool) -> int:
    """Rows of the per-knot parameters: per hand [p_ref (3); vec(R_ref) (9)], per obstacle [centre (3); yaw],
    then if compliant per hand F_ref and per hand F_meas [N]."""
    return 12 * n_hands + 4 * n_obstacles + (2 * n_hands if compliant else 0)


def task_residual_function(robot: Robot, weights, n_knots: int, clearances: tuple[Clearance, ...] = (),
                           footprint: tuple[tuple[float, float, float], ...] = (), soft: bool = False,
                           compliant: bool = False) -> cs.Function:
    """Weighted per-knot residual r(q, ref) = [sqrt(w_p/K)(p - p_ref - dp n); sqrt(w_o/K) vec(R - R_ref)] per
    hand, then if `soft`, sqrt(w_c/K) max(0, -margin) for every clearance margin (squared in the cost: C1).

    q = [joints; dp per hand if compliant]: dp is the compliant offset along the pad normal n = R e_z.
    ref: see knot_param_rows. ||R - R_ref||_F^2 = 2(3 - tr(R_ref^T R)) is sign-safe.
    """
    H, nd = len(robot.end_effectors), robot.n_dof
    q = cs.SX.sym("q", nd + (H if compliant else 0))
    ref = cs.SX.sym("ref", knot_param_rows(H, len(clearances), compliant))
    wp, wo = np.sqrt(weights.position / n_knots), np.sqrt(weights.orientation / n_knots)
    parts = []
    for h in range(H):
        p, R = robot.hand_pose(h, q[:nd])
        if compliant:
            p = p - R[:, 2] * q[nd + h]
        parts += [wp * (p - ref[12 * h: 12 * h + 3]), wo * (cs.vec(R) - ref[12 * h + 3: 12 * h + 12])]
    if soft:
        wc = np.sqrt(weights.clearance / n_knots)
        parts += [wc * cs.fmax(0, -m) for m in clearance_margins(robot, q[:nd], ref[12 * H:], clearances, footprint)]
    return cs.Function("task_residual", [q, ref], [cs.vertcat(*parts)])


def build_problem(robot: Robot, transcription, weights, chest_joints, mirrored_joints,
                  clearances: tuple[Clearance, ...] = (), footprint: tuple = (), clearance: str = "hard",
                  admittance=None) -> Problem:
    """The MPC-W problem from one spec for either transcription, modelled with OpTaS's builder. Clearance is
    `hard` (rows h(q_k) >= 0 at knots k >= 1) or `soft` (a squared-hinge cost term). With `admittance`, the
    transcription carries one compliant offset per hand after the joints (see task_residual_function)."""
    K, H, nd = transcription.n_knots, len(robot.end_effectors), robot.n_dof
    compliant = admittance is not None
    builder = optas.OptimizationBuilder(T=1)
    parts = [builder.add_decision_variables(name, *shape) for name, shape in transcription.variable_shapes.items()]
    x = cs.vertcat(*[cs.vec(v) for v in parts])
    ref = builder.add_parameter("knot_params", knot_param_rows(H, len(clearances), compliant), K)
    q, dq, ddq = transcription.knots(x)

    soft = clearance == "soft" and bool(clearances)
    task_residual = task_residual_function(robot, weights, K, clearances, footprint, soft, compliant)
    residual = task_residual.map(K)(q, ref)
    for h, hand in enumerate(robot.hand_names):
        builder.add_cost_term(f"position_{hand}", cs.sumsqr(residual[12 * h: 12 * h + 3, :]))
        builder.add_cost_term(f"orientation_{hand}", cs.sumsqr(residual[12 * h + 3: 12 * h + 12, :]))
    if soft:
        builder.add_cost_term("clearance", cs.sumsqr(residual[12 * H:, :]))

    moving = [i for i in range(robot.n_dof) if i not in robot.pinned_joints]
    chest = [robot.index(j) for j in chest_joints]
    arms = [i for i in moving if i not in robot.base_joints and i not in chest]
    home = robot.home[arms][:, None]
    linear = {
        "chest_yaw": np.sqrt(weights.chest_yaw / K) * q[chest, :],
        "arm_symmetry": np.sqrt(weights.arm_symmetry / K) * cs.vertcat(
            cs.SX(0, K), *[q[robot.index(a), :] + q[robot.index(b), :] for a, b in mirrored_joints]),
        "posture": np.sqrt(weights.posture / K) * (q[arms, :] - home),
        "velocity": np.sqrt(weights.velocity / K) * dq[moving, :],
        "acceleration": np.sqrt(weights.acceleration / ddq.shape[1]) * ddq[moving, :],
    }
    if compliant:  # F_hat = F_meas + m dp'' + D dp' + K dp -> F_ref at every knot (linear in x and p)
        ddq_k = ddq if ddq.shape[1] == K else cs.horzcat(ddq, ddq[:, -1])  # traditional: K - 1 differences
        w, forces = np.sqrt(admittance.weight / K), 12 * H + 4 * len(clearances)
        for h, hand in enumerate(robot.hand_names):
            f_hat = (ref[forces + H + h, :] + admittance.mass * ddq_k[nd + h, :]
                     + admittance.damping_value * dq[nd + h, :] + admittance.stiffness * q[nd + h, :])
            linear[f"admittance_{hand}"] = w * (f_hat - ref[forces + h, :])
    linear = {name: r for name, r in linear.items() if r.numel() > 0}  # e.g. a robot without a chest joint
    for name, r in linear.items():
        builder.add_cost_term(name, cs.sumsqr(r))
    optimization = builder.build()

    constraint = clearance_function(robot, clearances, footprint, compliant) if clearances and not soft else None
    r_lin, p = cs.vertcat(*[cs.vec(r) for r in linear.values()]), optimization.parameters.vec()
    if not cs.is_linear(r_lin, cs.vertcat(x, p)):
        raise ValueError("the linear cost residuals are not affine in the decision variables and parameters")
    L, S, c = (np.array(v) for v in cs.Function("lin", [x, p], [cs.jacobian(r_lin, x), cs.jacobian(r_lin, p),
                                                                r_lin])(np.zeros(x.numel()), np.zeros(p.numel())))
    A, lb, ub = linear_rows(x, transcription.linear_constraints(x, joint_limits(robot, admittance)[2]))
    return Problem(
        x=x, p=p, terms={k: optimization.cost_terms[k] for k in optimization.cost_terms},
        A=A, lb=lb, ub=ub, task_residual=task_residual,
        position_basis=transcription.position_basis, ref_shape=(ref.shape[0], K), L=L, c=c.ravel(), S=S,
        constraint=constraint if constraint is not None and constraint.numel_out(0) else None)


def joint_limits(robot: Robot, admittance=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lower, upper, velocity limit) of the MPC's q: the joints, then the compliant offsets if any."""
    n = len(robot.end_effectors) if admittance is not None else 0
    offset, rate = (admittance.max_offset, admittance.max_offset_rate) if n else (0.0, 0.0)
    return (np.r_[robot.lower, np.full(n, -offset)], np.r_[robot.upper, np.full(n, offset)],
            np.r_[robot.velocity_limit, np.full(n, rate)])


class WholeBodyMPC:
    """Built once; `step` solves from the measured state and reads out the command for the next period."""

    def __init__(self, robot: Robot, scenario, control_dt: float):
        start = time.perf_counter()
        self.robot, self.control_dt = robot, control_dt
        self.admittance = scenario.admittance if scenario.admittance.enabled else None
        self.n_hands = len(robot.end_effectors)
        self.limits = joint_limits(robot, self.admittance)
        self.transcription = make_transcription(scenario.mpc, self.limits[0].size)
        world, margin = scenario.world, scenario.planner.hand_radius
        shapes = [obstacle_shape(o) for o in world.obstacles]
        self.clearances = tuple(Clearance(s.kind, s.half, o.margin, o.margin + margin)
                                for o, s in zip(world.obstacles, shapes))
        legs = [leg for t in world.tables for leg in table_legs(t)]  # the base may pass under a table's top
        self.clearances += tuple(Clearance("box", leg.half, scenario.robot.base_margin, None) for leg in legs)
        # obstacle poses at every knot (rows of knot_params after the hand references); moving ones update them
        poses = [np.r_[s.centre, s.yaw] for s in shapes + legs]
        self.obstacle_poses = np.tile(np.concatenate(poses or [np.zeros(0)])[:, None], self.transcription.n_knots)
        self.problem = build_problem(robot, self.transcription, scenario.mpc.weights, scenario.robot.chest_joints,
                                     scenario.robot.mirrored_joints, self.clearances,
                                     tuple(map(tuple, scenario.robot.footprint)) if self.clearances else (),
                                     scenario.mpc.clearance, self.admittance)
        self.solver = make_solver(self.problem, scenario.solver)
        self.build_time = time.perf_counter() - start
        self.x = None  # last good solution
        self.pinned = list(robot.pinned_joints)
        self.force_filter = LowPass(self.admittance.force_filter, control_dt) if self.admittance else None
        self.force_seen = np.zeros(self.n_hands)  # the filtered pad forces the last step's admittance used [N]

    @property
    def knot_times(self) -> np.ndarray:
        return self.transcription.knot_times

    def set_obstacle_centres(self, centres: np.ndarray) -> None:
        """Predicted centres (obstacles, K, 3) of the world's obstacles (scenario order, the first clearances) at
        the knot times of the next `step`; yaws and table legs stay as built."""
        for o, at_knots in enumerate(centres):
            self.obstacle_poses[4 * o: 4 * o + 3] = at_knots.T

    def _constant(self, q_now: np.ndarray) -> np.ndarray:
        t = self.transcription
        positions = np.tile(q_now[:, None], t.position_basis.shape[1]).ravel("F")
        return np.concatenate([positions, np.zeros(t.n_vars - positions.size)])

    def step(self, q_now: np.ndarray, hand_ref: np.ndarray, force_ref: np.ndarray | None = None,
             force_meas: np.ndarray | None = None) -> tuple[Command, SolveResult]:
        """hand_ref: (12 * hands) x K references at the knot times (see task_residual_function); with admittance,
        force_ref: hands x K squeeze force references and force_meas: (hands,) measured pad normal forces [N]."""
        rows = [hand_ref, self.obstacle_poses]
        if self.admittance is not None:
            K = self.transcription.n_knots
            if force_meas is not None:
                self.force_seen = self.force_filter(force_meas)
            rows += [np.zeros((self.n_hands, K)) if force_ref is None else force_ref,
                     np.tile(self.force_seen, (K, 1)).T]
        self.params = np.vstack(rows).ravel(order="F")
        t, dt, robot = self.transcription, self.control_dt, self.robot
        q_init = np.r_[q_now, np.zeros(t.n_dof - q_now.size)]  # the compliant offsets start at 0
        q_init[self.pinned] = robot.home[self.pinned]
        lbx, ubx = t.bounds(*self.limits, q_init, self.pinned, robot.home[self.pinned])
        x0 = self._constant(q_init) if self.x is None else t.shift(self.x, dt)
        result = self.solver.solve(np.clip(x0, lbx, ubx), lbx, ubx, self.params)
        held = not result.success
        if held and self.x is None:
            raise RuntimeError(f"first whole-body MPC solve failed ({result.status}); no plan to hold")
        self.x = t.shift(self.x, dt) if held else result.x
        # A held plan is read out from its shifted copy: it continues from where it was, not from q_now.
        q_cmd, qd_cmd = t.readout(self.x, dt)
        base = list(robot.base_joints)  # velocity-commanded: the plan's mean velocity over the period
        qd_cmd[base] = (q_cmd[base] - t.readout(self.x, 0.0)[0][base]) / dt
        nd = robot.n_dof
        return Command(q_cmd[:nd], qd_cmd[:nd], held, q_cmd[nd:]), result
