"""The robot's motors as both engines model them: each joint's force limit."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from harmony_cli.robot.model import Robot

IDEAL_EFFORT = 1e4  # [N m | N] motor force limit of robot.actuators: ideal


def efforts(robot: Robot) -> np.ndarray:
    """Per joint, the motor's force limit: the URDF's effort, IDEAL_EFFORT off the base for actuators: ideal."""
    effort = np.array(robot.effort, dtype=float)
    if robot.actuators == "ideal":
        effort[[i for i in range(robot.n_dof) if i not in robot.base_joints]] = IDEAL_EFFORT
    return effort
