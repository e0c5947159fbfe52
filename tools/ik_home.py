"""A home pose for a robot preset by inverse kinematics: both pads at `reach` ahead of the base, `half` either side
of the centre line, at `height`, their normals facing each other; joint limits kept, mid-range preferred.

    .venv/bin/python tools/ik_home.py PRESET HEIGHT REACH HALF     (prints a `home:` line for the preset file)
"""

import sys
from pathlib import Path

import casadi as cs
import numpy as np
from scipy.optimize import least_squares

from harmony_cli.robot.model import load_robot
from harmony_cli.scenario import RobotSpec

name, height, reach, half = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
robot = load_robot(RobotSpec.model_validate({"preset": name}), Path.cwd())
free = [i for i in range(robot.n_dof) if i not in robot.base_joints]
q_ = cs.SX.sym("q", robot.n_dof)
fk = cs.Function(
    "fk",
    [q_],
    [
        cs.vertcat(
            *[
                cs.vertcat(
                    robot.model.get_global_link_position(link, q_), robot.model.get_global_link_rotation(link, q_)[:, 2]
                )
                for link in robot.end_effectors
            ]
        )
    ],
)
lo = np.maximum(robot.lower[free], -np.pi)
hi = np.minimum(robot.upper[free], np.pi)
mid = (lo + hi) / 2
target = np.r_[reach, half, height, 0, -1, 0, reach, -half, height, 0, 1, 0]


def res(x):
    q = robot.home.copy()
    q[free] = x
    e = np.array(fk(q)).ravel() - target
    return np.r_[e[:3], 0.3 * e[3:6], e[6:9], 0.3 * e[9:], 0.02 * (x - mid) / (hi - lo)]


best = None
rng = np.random.default_rng(0)
for trial in range(30):
    x0 = mid if trial == 0 else rng.uniform(lo, hi)
    r = least_squares(res, x0, bounds=(lo, hi))
    if best is None or r.cost < best.cost:
        best = r
q = robot.home.copy()
q[free] = best.x
print("cost", best.cost, "fk", np.round(np.array(fk(q)).ravel(), 3))
print(
    "home: {"
    + ", ".join(f"{robot.joint_names[i]}: {(q[i] if i in robot.prismatic else np.rad2deg(q[i])):.4g}" for i in free)
    + "}"
)
