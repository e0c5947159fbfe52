"""What the logs see of a simulation and the controllers never do, whichever engine runs it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harmony_cli.sim.contacts import PadContacts


@dataclass(frozen=True)
class Truth:
    """Ground truth the controllers never see, for the logs: the box, contacts, pushes, obstacles, clearances."""

    box_position: np.ndarray | None  # centre [m] (None: no box)
    box_z_axis: np.ndarray | None  # its z axis in the world (upright: ~ (0, 0, 1))
    box_pose: np.ndarray | None  # centre and quaternion (x, y, z, w): replays draw it
    box_touches_robot: bool
    pad_contacts: PadContacts | None  # per hand (links below its wrist sensor): contacts with the box, their force
    box_on_links: tuple[str, ...]  # the robot links of no hand the box touches (an arm, the chest), by name
    push_N: dict[str, float]  # push_<name>_N, the force acting over the coming physics steps
    obstacle_positions: dict[str, np.ndarray]  # moving obstacles' centres as the engine has them
    clearance_robot_m: dict[str, float]  # per obstacle, the robot's true distance (the engine's closest points)
    clearance_box_m: dict[str, float]  # per obstacle, the box's
    # per table and obstacle, the robot's deepest contact [m] (<= 0; nan: none) over the physics steps since the
    # last command (sim/touches.py); per obstacle, the box's
    contact_robot_m: dict[str, float]
    contact_box_m: dict[str, float]
