"""Has the simulation diverged? Checked every control step from what the simulator already reads (joint states,
hand positions) and once before the first step from PyBullet's contacts. Robots that started with their feet or
wheels inside the ground were thrown 50-270 m within 0.04 s, and those runs went on to "complete": a run that
goes on from there measures nothing, so it stops as failed, saying what diverged, where and when."""

from __future__ import annotations

import numpy as np

from harmony_cli.experiment.faults import RunFault
from harmony_cli.robot.model import Robot

# A velocity-commanded base cannot move ten times faster than its limit allows; such a step is the contact solver
# throwing the robot, not motion. The cap covers bases whose URDF gives no or a huge limit (harmony's: 1.5 m/s).
BASE_SPEED_FACTOR = 10.0
BASE_JUMP_M = 0.5  # [m] per control step, at most
# Position control and contacts push a joint a little past its URDF limit (the MPC keeps the targets inside);
# this far past it, the joint was thrown.
JOINT_SLACK_RAD = 0.5
JOINT_SLACK_M = 0.1
# The hands start on their reference and the planner re-plans from them; 2 m is beyond any of these arms' reach:
# the robot is somewhere else entirely.
TRACKING_LIMIT_M = 2.0
# Resting contacts at the start are within millimetres (the presets: <= 1.2 mm); deeper, the robot starts inside
# the ground or an obstacle and the contact solver throws it out at the first physics step.
PENETRATION_M = 0.02


def check_start(contacts: list[tuple[str, str, float]]) -> None:
    """Refuse a start with the robot (link, other body, signed distance) deeper than PENETRATION_M in another."""
    deep = [c for c in contacts if c[2] < -PENETRATION_M]
    if deep:
        link, other, distance = min(deep, key=lambda c: c[2])
        raise RunFault(
            "penetration",
            f"at the start (t = 0.00 s) the robot's link {link} is {100 * -distance:.1f} cm inside {other} "
            f"(at most {100 * PENETRATION_M:g} cm): the simulator would throw it out; start it clear "
            "(robot.mount, robot.base_pose, the world's bodies)",
        )


class Health:
    """The per-step checks of one run: joints far past their URDF limits, the base jumping, the hands far from
    their references. `check` raises RunFault("diverged", what, where, when)."""

    def __init__(self, robot: Robot, control_dt: float):
        n = robot.n_dof
        slack = np.full(n, JOINT_SLACK_RAD)
        slack[list(robot.prismatic)] = JOINT_SLACK_M
        unbounded = np.zeros(n, dtype=bool)
        unbounded[list(robot.continuous)] = True
        self.lower = np.where(unbounded, -np.inf, robot.lower - slack)
        self.upper = np.where(unbounded, np.inf, robot.upper + slack)
        self.robot, self.dt = robot, control_dt
        self.base = list(robot.base_joints[:2])  # x, y
        speed = float(np.hypot(*robot.velocity_limit[self.base]))
        self.max_jump = min(BASE_JUMP_M, BASE_SPEED_FACTOR * speed * control_dt) if speed > 0 else BASE_JUMP_M
        self.last_base: np.ndarray | None = None

    def check(self, t: float, q: np.ndarray, hands: np.ndarray, references: np.ndarray) -> None:
        """q: measured joints; hands, references: (hands, 3) measured and referenced hand positions now."""
        inside = (q >= self.lower) & (q <= self.upper)  # NaN is outside
        if not inside.all():
            self._joint(t, q, ~inside)
        base = q[self.base]
        if self.last_base is not None:
            moved = base - self.last_base
            if (jump := float(np.sqrt(moved @ moved))) > self.max_jump:
                raise RunFault(
                    "diverged",
                    f"the base moved {jump:.2f} m in one control step ({self.dt:g} s) to t = {t:.2f} s, to "
                    f"({base[0]:.2f}, {base[1]:.2f}) m (at most {self.max_jump:.2f} m)",
                )
        self.last_base = base
        off = hands - references
        if not ((off * off).sum(axis=1) <= TRACKING_LIMIT_M**2).all():  # squares: no square root every step
            errors = np.linalg.norm(off, axis=1)
            h = int(np.argmax(np.where(np.isnan(errors), np.inf, errors)))
            raise RunFault(
                "diverged",
                f"the {self.robot.hand_names[h]} hand is {errors[h]:.2f} m from its reference at t = {t:.2f} s "
                f"(at most {TRACKING_LIMIT_M:g} m)",
            )

    def _joint(self, t: float, q: np.ndarray, outside: np.ndarray) -> None:
        beyond = np.where(outside, np.maximum(self.lower - q, q - self.upper), -np.inf)
        j = int(np.argmax(np.where(np.isnan(q), np.inf, beyond)))  # the worst joint
        robot, prismatic = self.robot, j in self.robot.prismatic
        unit, slack = ("m", JOINT_SLACK_M) if prismatic else ("rad", JOINT_SLACK_RAD)
        raise RunFault(
            "diverged",
            f"joint {robot.joint_names[j]} at {q[j]:.3f} {unit} at t = {t:.2f} s, outside its URDF limits "
            f"[{robot.lower[j]:.3f}, {robot.upper[j]:.3f}] {unit} by more than {slack:g} {unit}",
        )
