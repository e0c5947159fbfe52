"""What the arms reach with the pads level and facing each other (each hand's rotation its home one turned about
the vertical, as the task-space planner plans them), every joint within its limits, the base on the floor at the
origin and the pinned joints at home:

- the ceiling: the highest both hands get together, at one height and `width` apart. The task-space planner keeps
  its hands below it: a plan above it is one the whole-body MPC cannot follow (it saturates the joints and the
  held box ends lower than planned, e.g. on an obstacle the plan lifts it over);
- the radius: the farthest one hand gets from the base's origin in plan view at a height. The scene check refuses
  a hand target that no clear base pose has within it.

Each is a small NLP (IPOPT) from the home pose and a few seeded random ones, the best converged optimum kept: a
local optimum from each, so a value the arms do reach, not a bound on every value they might (the scene check
adds a slack). Worked out once per robot and question (~0.2 s) and cached on disk."""

from __future__ import annotations

import casadi as cs
import numpy as np

from harmony_cli.cache import cached_json
from harmony_cli.capture import captured_output
from harmony_cli.robot.model import Robot

STARTS = 6  # the home pose, then seeded random poses within the limits
ROTATION_TOL = 1e-4  # ||R - Rz(psi) R_home||_F^2 allowed per hand (about 0.4 deg)


def hand_ceiling(robot: Robot, width: float) -> float | None:
    """[m] the highest both hands reach together `width` apart (world z; the base's planar joints do not change
    it); None when no start converged."""
    return _cached(robot, ("ceiling", round(width, 4)), lambda: _value(highest_pose(robot, width)))


def hand_radius(robot: Robot, hand: int, height: float) -> float | None:
    """[m] the farthest hand number `hand` reaches from the base's origin in plan view with its pad level at
    `height` [m] (world z); None when no start converged (the height is out of reach)."""
    return _cached(robot, ("radius", hand, round(height, 4)), lambda: _value(farthest_pose(robot, hand, height)))


def highest_pose(robot: Robot, width: float) -> tuple[float, np.ndarray] | None:
    """The hands' highest height [m] `width` apart and the joint positions (all joints) that reach it."""
    level = _Level(robot)
    (p0, _), (p1, _) = level.poses
    return level.best(0.5 * (p0[2] + p1[2]), [p0[2] - p1[2], cs.sumsqr(p1 - p0) - width**2], (0, 1))


def farthest_pose(robot: Robot, hand: int, height: float) -> tuple[float, np.ndarray] | None:
    """The hand's farthest plan-view distance [m] from the base's origin at `height` and the joint positions."""
    level = _Level(robot)
    p = level.poses[hand][0]
    found = level.best(cs.sumsqr(p[:2]), [p[2] - height], (hand,))
    return None if found is None else (float(np.sqrt(max(found[0], 0.0))), found[1])


def _value(found: tuple[float, np.ndarray] | None) -> float | None:
    return None if found is None else found[0]


def _cached(robot: Robot, question: tuple, compute) -> float | None:
    home = home_at_origin(robot)
    key = (robot.joint_names, robot.end_effectors, robot.pinned_joints, home.tolist(), question)
    return cached_json("reach", robot.urdf.read_bytes() + repr(key).encode(), compute)


def home_at_origin(robot: Robot) -> np.ndarray:
    """The home pose with the base at the origin (where the robot starts does not change its arms)."""
    home = robot.home.copy()
    home[list(robot.base_joints)] = 0.0
    return home


def arm_joints(robot: Robot) -> tuple[list[int], np.ndarray, np.ndarray]:
    """The joints that move but the base's, the pinned ones and mimic joints (their leaders move them: `coupled`)
    (indices), and their bounds (continuous: none)."""
    held = {*robot.base_joints, *robot.pinned_joints, *(c.follower for c in robot.couplings)}
    free = [i for i in range(robot.n_dof) if i not in held]
    unbounded = np.isin(free, robot.continuous)
    return free, np.where(unbounded, -np.inf, robot.lower[free]), np.where(unbounded, np.inf, robot.upper[free])


class _Level:
    """The joints that move (not the base, not the pinned ones) as NLP variables, with a heading psi for the pads."""

    def __init__(self, robot: Robot):
        self.robot, self.home = robot, home_at_origin(robot)
        self.free, self.lower, self.upper = arm_joints(robot)
        self.x, self.psi = cs.SX.sym("x", len(self.free)), cs.SX.sym("psi")
        q = cs.SX(self.home)
        for k, i in enumerate(self.free):
            q[i] = self.x[k]
        q = robot.coupled(q)
        self.poses = [robot.hand_pose(h, q) for h in range(len(robot.end_effectors))]
        self.home_rotations = [r for _, r in robot.hand_poses_numeric(self.home)]

    def best(self, objective, equalities: list, hands: tuple[int, ...]) -> tuple[float, np.ndarray] | None:
        """The largest `objective` over the starts with the `equalities` = 0 and the `hands`' pads level, turned
        together about the vertical: ||R_h - Rz(psi) R_h,home||_F^2 <= ROTATION_TOL."""
        free, lower, upper = self.free, self.lower, self.upper
        c, s = cs.cos(self.psi), cs.sin(self.psi)
        turn = cs.vertcat(cs.horzcat(c, -s, 0), cs.horzcat(s, c, 0), cs.horzcat(0, 0, 1))
        rotations = [cs.sumsqr(self.poses[h][1] - turn @ cs.DM(self.home_rotations[h])) for h in hands]
        nlp = {"x": cs.vertcat(self.x, self.psi), "f": -objective, "g": cs.vertcat(*equalities, *rotations)}
        options = {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": 300, "ipopt.sb": "yes"}
        solver = cs.nlpsol("reach", "ipopt", nlp, options)
        ubg = np.r_[np.zeros(len(equalities)), np.full(len(hands), ROTATION_TOL)]
        rng = np.random.default_rng(0)
        best: tuple[float, np.ndarray] | None = None
        for start in range(STARTS):
            x0 = self.home[free] if start == 0 else rng.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))
            with captured_output():
                out = solver(x0=np.r_[x0, 0.0], lbx=np.r_[lower, -np.inf], ubx=np.r_[upper, np.inf], lbg=0.0, ubg=ubg)
            if solver.stats()["success"] and (best is None or -float(out["f"]) > best[0]):
                q = self.home.copy()
                q[free] = np.asarray(out["x"]).ravel()[:-1]
                best = -float(out["f"]), self.robot.coupled(q)
        return best
