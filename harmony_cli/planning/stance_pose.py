"""A base pose to work from when the written stance is blocked: one pose (x, y, yaw) of the base, clear of every
obstacle and table leg, from which the hands reach every target of a group of phases with the pads as the planner
plans them (level, turned about the vertical to face each other), every joint within its limits.

Clear means as the whole-body MPC keeps it (its own clearance rows: footprint and hands), with an obstacle's margin
a preference and its body a hard limit: a relief per obstacle (how far its margins are lowered, down to
clearance.FLOOR) is a variable of the search with an exact L1 penalty, so the pose keeps every margin where one
that does exists near the start and goes into a margin only as far as the scene makes it. The whole-body MPC gets
the pose's reliefs for the group's phases (stance_plan.py).

Why: the whole-body MPC only tracks the hands; where the base stands follows from its local optimum, which starts
from the base behind the hands as at home. When an obstacle's margin holds the base off that spot, the optimum
lets a hand sag or the grip twist rather than walk the base round to a pose that works. This IK is global in the
base (seeded at headings all round the targets); the planner routes the hands through the pose's position
(stance_plan.py), so the base, which follows them, arrives on the side where it can stand.

The base's footprint may pass under a table's top (between its legs); the body it carries may not (robot.trunk).
The arms' rows against table tops and obstacles (robot.arm_radius) are the whole-body MPC's alone: starts whose
arms pass through a table would meet local infeasibility.

One NLP (IPOPT): the base and the reliefs shared, a joint vector per phase, the arms' distance from home and the
reliefs as the cost. Each start is a local solve: a pose found is one that works; none found is not a proof that
none exists."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as cs
import numpy as np

from harmony_cli.capture import captured_output
from harmony_cli.maths.rotations import rot_z
from harmony_cli.maths.shapes import symbolic_distance
from harmony_cli.mpc.clearance import clearance_margins, scene_clearances
from harmony_cli.mpc.knot_params import KnotLayout
from harmony_cli.robot.model import Robot
from harmony_cli.robot.reach import arm_joints, home_at_origin
from harmony_cli.scenario import Scenario
from harmony_cli.tasks.as_written import trunk_under_tops

TURNS_DEG = (0, 45, -45, 90, -90, 135, -135, 180)  # base headings tried, from the written one
# where the searches start: (turn from the written heading [deg], distance behind the targets as a share of home's)
STARTS = tuple((turn, 1.0) for turn in TURNS_DEG)
POSITION_TOL = 0.01  # [m] each hand from its target
ROTATION_TOL = 1e-3  # ||R - R_ref||_F^2 per hand (about 1.3 deg)
SAME_M, SAME_RAD = 0.05, np.deg2rad(5)  # two poses this close in position and yaw are one
# cost per metre of relief, against the arms' squared distance from home [rad^2]: above what a centimetre of margin
# saves the arms, so a relief is taken only where the scene leaves no pose that keeps the margin
RELIEF_COST = 1e3
RELIEVED = 1e-3  # [m] a relief below this is none (the solver's tolerance)


@dataclass(frozen=True)
class StancePose:
    """The base pose (x, y, yaw) [m, rad], the joints per phase (phases, all joints) and per world obstacle
    (scenario order) how far the pose goes into its margin [m] (0: keeps it)."""

    base: np.ndarray
    joints: np.ndarray
    reliefs: np.ndarray

    @property
    def relieved(self) -> bool:
        return bool(self.reliefs.max(initial=0.0) > RELIEVED)


def _joint_vector(robot: Robot, home: np.ndarray, free: list[int], x: cs.SX, base: cs.SX) -> cs.SX:
    """The home pose with the `free` joints at `x`, the base's at `base` and mimic joints on their leaders."""
    q = cs.SX(home)
    for k, i in enumerate(free):
        q[i] = x[k]
    for k, i in enumerate(robot.base_joints):
        q[i] = base[k]
    return robot.coupled(q)


def stance_poses(
    scenario: Scenario,
    robot: Robot,
    targets: np.ndarray,
    headings: np.ndarray,
    first: bool = False,
    starts: tuple[tuple[float, float], ...] = STARTS,
) -> list[StancePose]:
    """The poses from which the hands reach `targets` (phases, hands, 3) with the pads turned to `headings`
    (phases,) (the planner's heading: 0 at home), clear of the scene, from every one of `starts` (STARTS) that
    converges: least relief first, else in the order tried (`first`: stop at the first that keeps every margin,
    then first), the same pose found twice (within SAME_M and SAME_RAD) once."""
    home = home_at_origin(robot)
    # headings are the planner's, 0 at home as the robot starts: the pads turn from there, the base from its yaw
    rotations = [r for _, r in robot.hand_poses_numeric(robot.home)]
    start_yaw = float(robot.home[robot.base_joints[2]])
    free, lower, upper = arm_joints(robot)
    base = cs.SX.sym("base", 3)
    margins, reliefs, gives = _relieved_margins(scenario, robot)
    n_obstacles = reliefs.numel()
    variables, rows, cost = [], _trunk_rows(scenario, base), RELIEF_COST * cs.sum1(reliefs)
    for pair, heading in zip(targets, headings):
        x = cs.SX.sym("x", len(free))
        q = _joint_vector(robot, home, free, x, base)
        turn = rot_z(np.asarray(heading))
        for h, target in enumerate(pair):
            p, R = robot.hand_pose(h, q)
            rows += [(p - target, -POSITION_TOL, POSITION_TOL), (cs.sumsqr(R - turn @ rotations[h]), 0.0, ROTATION_TOL)]
        if margins is not None:
            rows.append((cs.vertcat(*margins(q)), 0.0, np.inf))
        variables.append(x)
        cost += cs.sumsqr(x - home[free])
    g, lbg, ubg = _stacked(rows)
    lbx = np.r_[np.full(3, -np.inf), np.zeros(n_obstacles), np.tile(lower, len(targets))]
    ubx = np.r_[np.full(3, np.inf), gives, np.tile(upper, len(targets))]
    options = {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": 300, "ipopt.sb": "yes"}
    solver = cs.nlpsol("stance", "ipopt", {"x": cs.vertcat(base, reliefs, *variables), "f": cost, "g": g}, options)
    # the hands' midpoint at home from the base's origin, in the base frame (plan view)
    behind = np.mean([p.ravel()[:2] for p, _ in robot.hand_poses_numeric(home)], axis=0)
    middle = targets.mean(axis=(0, 1))[:2]
    found: list[StancePose] = []
    for turn_deg, share in starts:
        yaw = start_yaw + float(headings[-1]) + np.deg2rad(turn_deg)
        start = np.r_[middle - share * rot_z(np.asarray(yaw))[:2, :2] @ behind, yaw, gives]
        with captured_output():
            out = solver(x0=np.r_[start, np.tile(home[free], len(targets))], lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        if not solver.stats()["success"]:
            continue
        x = np.asarray(out["x"]).ravel()
        joints = np.tile(home, (len(targets), 1))
        joints[:, free] = x[3 + n_obstacles :].reshape(len(targets), len(free))
        joints[:, list(robot.base_joints)] = x[:3]
        joints = robot.coupled(joints)
        pose = StancePose(x[:3], joints, np.where(x[3 : 3 + n_obstacles] > RELIEVED, x[3 : 3 + n_obstacles], 0.0))
        if not any(_same(pose.base, other.base) for other in found):
            found.append(pose)
        if first and not pose.relieved:
            break
    return sorted(found, key=lambda pose: float(pose.reliefs.sum()))


def _relieved_margins(scenario: Scenario, robot: Robot):
    """The whole-body MPC's clearance margins as a function of q (None: nothing to clear), with a relief per world
    obstacle as a variable (symbols, scenario order) and how far each may go (its give)."""
    clearances, poses = scene_clearances(scenario.world, scenario.planner.hand_radius, scenario.robot.base_margin)
    layout = KnotLayout(len(robot.end_effectors), len(clearances))
    n_obstacles = len(scenario.world.obstacles)  # the first clearances, the only ones that give
    reliefs = cs.SX.sym("relief", n_obstacles)
    ref = cs.SX(np.r_[np.zeros(layout.hands_end), poses])
    for o in range(n_obstacles):
        ref[layout.obstacle_relief(o)] = reliefs[o]
    footprint = tuple((x, y, r) for x, y, r in scenario.robot.footprint)
    gives = np.array([c.give for c in clearances[:n_obstacles]])
    if not clearances:
        return None, reliefs, gives
    return (lambda q: clearance_margins(robot, q, ref, layout, clearances, footprint)), reliefs, gives


def _stacked(rows: list) -> tuple:
    """The rows (expression, lower, upper) as one constraint vector and its bounds."""
    g = cs.vertcat(*[r for r, _, _ in rows])
    lbg = np.concatenate([np.full(r.numel(), lo) for r, lo, _ in rows])
    return g, lbg, np.concatenate([np.full(r.numel(), hi) for r, _, hi in rows])


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    turn = (a[2] - b[2] + np.pi) % (2 * np.pi) - np.pi
    return bool(np.hypot(*(a[:2] - b[:2])) <= SAME_M and abs(turn) <= SAME_RAD)


def _trunk_rows(scenario: Scenario, base: cs.SX) -> list:
    """Each trunk circle out from under each table top at its height (robot.trunk): the footprint's clearance rows
    keep only the table legs, which a base lower than the top passes between."""
    c, s = cs.cos(base[2]), cs.sin(base[2])
    rows = []
    for (x, y, radius), top in trunk_under_tops(scenario):
        point = cs.vertcat(base[0] + c * x - s * y, base[1] + s * x + c * y, top.centre[2])
        distance = symbolic_distance(top.kind, top.half, top.centre, top.yaw, point, planar=True)
        rows.append((distance - radius, 0.0, np.inf))
    return rows
