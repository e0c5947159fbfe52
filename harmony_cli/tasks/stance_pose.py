"""A base pose to work from when the written stance is blocked: one pose (x, y, yaw) of the base, clear of every
obstacle and table leg by the margins the whole-body MPC keeps (its own clearance rows: footprint and hands), from
which the hands reach every target of a group of phases with the pads as the planner plans them (level, turned
about the vertical to face each other), every joint within its limits.

Why: the whole-body MPC only tracks the hands; where the base stands follows from its local optimum, which starts
from the base behind the hands as at home. When an obstacle's margin holds the base off that spot, the optimum
lets a hand sag or the grip twist rather than walk the base round to a pose that works. This IK is global in the
base (seeded at headings all round the targets); the planner routes the hands through the pose's position
(stance_plan.py), so the base, which follows them, arrives on the side where it can stand.

The base's footprint may pass under a table's top (between its legs); the body it carries may not (robot.trunk):
without that row the pose found for a place blocked from its front stood the base under the table from behind,
the waist inside the top, and the carry drove round the table to get there.

The arms' rows against table tops and obstacles (robot.arm_radius) are the whole-body MPC's alone: with them this
search, from starts whose arms pass through a table, met local infeasibility where it had found a pose that keeps
them (a place blocked from its front: no start of eight converged, and the search took 2.5 times as long).

One NLP (IPOPT): the base shared, a joint vector per phase, the arms' distance from home as the cost. Each start
is a local solve: a pose found is one that works; none found is not a proof that none exists."""

from __future__ import annotations

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


def stance_pose(
    scenario: Scenario, robot: Robot, targets: np.ndarray, headings: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """The base pose (x, y, yaw) [m, rad] from which the hands reach `targets` (phases, hands, 3) with the pads
    turned to `headings` (phases,) (the planner's heading: 0 at home), clear of the scene, and the joint positions
    (phases, all joints) that do; from the first start that converges (the written heading's first, then turned
    ever further from it); None if none converged."""
    found = stance_poses(scenario, robot, targets, headings, first=True)
    return found[0] if found else None


def stance_poses(
    scenario: Scenario,
    robot: Robot,
    targets: np.ndarray,
    headings: np.ndarray,
    first: bool = False,
    starts: tuple[tuple[float, float], ...] = STARTS,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """stance_pose's poses from every one of `starts` (STARTS) that converges, in the order tried (`first`: stop at
    the first), the same pose found twice (within SAME_M and SAME_RAD) once."""
    home = home_at_origin(robot)
    # headings are the planner's, 0 at home as the robot starts: the pads turn from there, the base from its yaw
    rotations = [r for _, r in robot.hand_poses_numeric(robot.home)]
    start_yaw = float(robot.home[robot.base_joints[2]])
    free, lower, upper = arm_joints(robot)
    base = cs.SX.sym("base", 3)
    clearances, poses = scene_clearances(scenario.world, scenario.planner.hand_radius, scenario.robot.base_margin)
    layout = KnotLayout(len(robot.end_effectors), len(clearances))
    ref = np.r_[np.zeros(layout.hands_end), poses]
    footprint = tuple((x, y, r) for x, y, r in scenario.robot.footprint) if clearances else ()
    variables, rows, cost = [], _trunk_rows(scenario, base), 0
    for pair, heading in zip(targets, headings):
        x = cs.SX.sym("x", len(free))
        q = cs.SX(home)
        for k, i in enumerate(free):
            q[i] = x[k]
        for k, i in enumerate(robot.base_joints):
            q[i] = base[k]
        turn = rot_z(np.asarray(heading))
        for h, target in enumerate(pair):
            p, R = robot.hand_pose(h, q)
            rows += [(p - target, -POSITION_TOL, POSITION_TOL), (cs.sumsqr(R - turn @ rotations[h]), 0.0, ROTATION_TOL)]
        if clearances:
            rows.append((cs.vertcat(*clearance_margins(robot, q, ref, layout, clearances, footprint)), 0.0, np.inf))
        variables.append(x)
        cost += cs.sumsqr(x - home[free])
    g, lbg, ubg = _stacked(rows)
    lbx = np.r_[np.full(3, -np.inf), np.tile(lower, len(targets))]
    ubx = np.r_[np.full(3, np.inf), np.tile(upper, len(targets))]
    options = {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": 300, "ipopt.sb": "yes"}
    solver = cs.nlpsol("stance", "ipopt", {"x": cs.vertcat(base, *variables), "f": cost, "g": g}, options)
    behind = _behind(robot, home)
    middle = targets.mean(axis=(0, 1))[:2]
    found: list[tuple[np.ndarray, np.ndarray]] = []
    for turn_deg, share in starts:
        yaw = start_yaw + float(headings[-1]) + np.deg2rad(turn_deg)
        start = np.r_[middle - share * rot_z(np.asarray(yaw))[:2, :2] @ behind, yaw]
        with captured_output():
            out = solver(x0=np.r_[start, np.tile(home[free], len(targets))], lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        if not solver.stats()["success"]:
            continue
        x = np.asarray(out["x"]).ravel()
        joints = np.tile(home, (len(targets), 1))
        joints[:, free] = x[3:].reshape(len(targets), len(free))
        joints[:, list(robot.base_joints)] = x[:3]
        if not any(_same(x[:3], base) for base, _ in found):
            found.append((x[:3], joints))
        if first:
            break
    return found


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


def _behind(robot: Robot, home: np.ndarray) -> np.ndarray:
    """The hands' midpoint at home from the base's origin, in the base frame (plan view)."""
    return np.mean([p.ravel()[:2] for p, _ in robot.hand_poses_numeric(home)], axis=0)
