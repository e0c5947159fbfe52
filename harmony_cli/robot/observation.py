"""What a controller sees of the robot and the object it handles: the measurement the simulator (or a real robot)
hands over every control step. Controllers get this, never the simulator."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Observation:
    q: np.ndarray  # measured joint positions, robot joint order
    qd: np.ndarray
    hand_positions: np.ndarray  # (hands, 3) world positions of the end-effector frames
    hand_rotations: np.ndarray  # (hands, 3, 3)
    hand_velocities: np.ndarray  # (hands, 3) world linear velocities
    heading_rate: float  # mean yaw rate of the hands [rad/s]
    wrenches: np.ndarray  # (hands, 6) external force and torque on each tool, grasp frame (see sim/wrench.py)
    box_position: np.ndarray | None = None  # the carried object's measured centre [m] (None: no object)
    box_yaw: float = 0.0  # its yaw [rad]

    @property
    def pad_forces(self) -> np.ndarray:
        """Per hand, the force pressing on the pad [N]: the grasp z axis points out of the pad, so an object pushing
        back on it gives a force along -z, read positive (a squeeze > 0, a pull < 0)."""
        return -self.wrenches[:, 2]
