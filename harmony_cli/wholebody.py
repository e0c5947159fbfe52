"""Whole-body MPC (MPC-W): track both hands' poses at K knots with all joints, built once, warm-started."""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as cs
import numpy as np
import optas

from harmony_cli.geometry import symbolic_distance
from harmony_cli.robot import Robot
from harmony_cli.solvers import Problem, SolveResult, linear_rows, make_solver
from harmony_cli.transcription import make_transcription
from harmony_cli.world import obstacle_shape, table_legs


@dataclass(frozen=True)
class Command:
    q: np.ndarray  # position targets at t + control_dt
    qd: np.ndarray  # velocity targets (base: mean velocity over the control period)
    held: bool  # True when the solve failed and the last good plan was used


@dataclass(frozen=True)
class Clearance:
    """An obstacle as the whole-body MPC sees it: its centre (3) and yaw are parameters at every knot (so it
    may move); the base footprint circles keep `base` [m] from it in x, y and the hands `hand` [m] in 3-D
    (None: the hands may touch it, e.g. a table)."""

    kind: str
    half: np.ndarray
    base: float
    hand: float | None


def task_residual_function(robot: Robot, weights, n_knots: int, clearances: tuple[Clearance, ...] = (),
                           footprint: tuple[tuple[float, float, float], ...] = ()) -> cs.Function:
    """Weighted per-knot residual r(q, ref) = [sqrt(w_p/K)(p - p_ref); sqrt(w_o/K) vec(R - R_ref)] per hand, then
    sqrt(w_c/K) max(0, needed - distance) for every (footprint circle | hand, obstacle) pair.

    ref stacks per hand [p_ref (3); vec(R_ref) (9)], then per obstacle [centre (3); yaw];
    ||R - R_ref||_F^2 = 2(3 - tr(R_ref^T R)) is sign-safe. The hinge is squared in the cost: C1.
    """
    H = len(robot.end_effectors)
    q = cs.SX.sym("q", robot.n_dof)
    ref = cs.SX.sym("ref", 12 * H + 4 * len(clearances))
    wp, wo = np.sqrt(weights.position / n_knots), np.sqrt(weights.orientation / n_knots)
    wc = np.sqrt(weights.clearance / n_knots)
    parts, hands = [], []
    for h in range(H):
        p, R = robot.hand_pose(h, q)
        hands.append(p)
        parts += [wp * (p - ref[12 * h: 12 * h + 3]), wo * (cs.vec(R) - ref[12 * h + 3: 12 * h + 12])]
    bx, by, byaw = (q[i] for i in robot.base_joints)
    circles = [(cs.vertcat(bx + cs.cos(byaw) * x - cs.sin(byaw) * y, by + cs.sin(byaw) * x + cs.cos(byaw) * y, 0),
                r) for x, y, r in footprint]
    for o, obstacle in enumerate(clearances):
        centre, yaw = ref[12 * H + 4 * o: 12 * H + 4 * o + 3], ref[12 * H + 4 * o + 3]
        for point, radius in circles:
            d = symbolic_distance(obstacle.kind, obstacle.half, centre, yaw, point, planar=True)
            parts.append(wc * cs.fmax(0, obstacle.base + radius - d))
        if obstacle.hand is not None:
            for p in hands:
                parts.append(wc * cs.fmax(0, obstacle.hand - symbolic_distance(obstacle.kind, obstacle.half,
                                                                                 centre, yaw, p)))
    return cs.Function("task_residual", [q, ref], [cs.vertcat(*parts)])


def build_problem(robot: Robot, transcription, weights, chest_joints, mirrored_joints,
                  clearances: tuple[Clearance, ...] = (), footprint: tuple = ()) -> Problem:
    """The MPC-W problem from one spec for either transcription, modelled with OpTaS's builder."""
    K, H = transcription.n_knots, len(robot.end_effectors)
    builder = optas.OptimizationBuilder(T=1)
    parts = [builder.add_decision_variables(name, *shape) for name, shape in transcription.variable_shapes.items()]
    x = cs.vertcat(*[cs.vec(v) for v in parts])
    ref = builder.add_parameter("knot_params", 12 * H + 4 * len(clearances), K)  # hand refs, obstacle poses
    q, dq, ddq = transcription.knots(x)

    task_residual = task_residual_function(robot, weights, K, clearances, footprint)
    residual = task_residual.map(K)(q, ref)
    for h, hand in enumerate(robot.hand_names):
        builder.add_cost_term(f"position_{hand}", cs.sumsqr(residual[12 * h: 12 * h + 3, :]))
        builder.add_cost_term(f"orientation_{hand}", cs.sumsqr(residual[12 * h + 3: 12 * h + 12, :]))
    if clearances:
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
    linear = {name: r for name, r in linear.items() if r.numel() > 0}  # e.g. a robot without a chest joint
    for name, r in linear.items():
        builder.add_cost_term(name, cs.sumsqr(r))
    optimization = builder.build()

    r_lin = cs.vertcat(*[cs.vec(r) for r in linear.values()])
    L, c = (np.array(v) for v in cs.Function("lin", [x], [cs.jacobian(r_lin, x), r_lin])(np.zeros(x.numel())))
    A, lb, ub = linear_rows(x, transcription.linear_constraints(x, robot.velocity_limit))
    return Problem(
        x=x, p=optimization.parameters.vec(), terms={k: optimization.cost_terms[k] for k in optimization.cost_terms},
        A=A, lb=lb, ub=ub, task_residual=task_residual,
        position_basis=transcription.position_basis, ref_shape=(ref.shape[0], K), L=L, c=c.ravel())


class WholeBodyMPC:
    """Built once; `step` solves from the measured state and reads out the command for the next period."""

    def __init__(self, robot: Robot, scenario, control_dt: float):
        start = time.perf_counter()
        self.robot, self.control_dt = robot, control_dt
        self.transcription = make_transcription(scenario.mpc, robot.n_dof)
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
                                     tuple(map(tuple, scenario.robot.footprint)) if self.clearances else ())
        self.solver = make_solver(self.problem, scenario.solver)
        self.build_time = time.perf_counter() - start
        self.x = None  # last good solution
        self.pinned = list(robot.pinned_joints)

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

    def step(self, q_now: np.ndarray, hand_ref: np.ndarray) -> tuple[Command, SolveResult]:
        """hand_ref: (12 * hands) x K references at the knot times (see task_residual_function)."""
        self.params = np.vstack([hand_ref, self.obstacle_poses]).ravel(order="F")
        t, dt, robot = self.transcription, self.control_dt, self.robot
        q_init = q_now.copy()
        q_init[self.pinned] = robot.home[self.pinned]
        lbx, ubx = t.bounds(robot.lower, robot.upper, robot.velocity_limit, q_init, self.pinned,
                            robot.home[self.pinned])
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
        return Command(q_cmd, qd_cmd, held), result
