"""What the logs see of a simulation and the controllers never do, whichever engine runs it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

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


@dataclass(frozen=True)
class BoxTruth:
    """What an engine measures of the box: its centre, z axis and (x, y, z, w) quaternion, whether it touches the
    robot, its contacts with the pads (and other links, by name), its clearance per obstacle."""

    centre: np.ndarray
    z_axis: np.ndarray
    quaternion: np.ndarray
    touches_robot: bool
    pads: PadContacts
    on_links: tuple[str, ...]
    clearance_m: dict[str, float]


class Touched(Protocol):
    """An engine's record of the deepest contacts since the last command (sim/touches.py)."""

    robot_m: dict[str, float]
    box_m: dict[str, float]
    robot_bodies: list[str]
    box_bodies: list[str]


def assemble(
    box: BoxTruth | None,
    push_N: dict[str, float],
    obstacle_positions: dict[str, np.ndarray],
    clearance_robot_m: dict[str, float],
    touches: Touched,
) -> Truth:
    """The Truth of an engine's measurements (no box: its fields empty); untouched bodies' contacts nan."""
    nan = float("nan")
    return Truth(
        box_position=None if box is None else box.centre,
        box_z_axis=None if box is None else box.z_axis,
        box_pose=None if box is None else np.concatenate([box.centre, box.quaternion]),
        box_touches_robot=box is not None and box.touches_robot,
        pad_contacts=None if box is None else box.pads,
        box_on_links=() if box is None else box.on_links,
        push_N=push_N,
        obstacle_positions=obstacle_positions,
        clearance_robot_m=clearance_robot_m,
        clearance_box_m={} if box is None else box.clearance_m,
        contact_robot_m={name: touches.robot_m.get(name, nan) for name in touches.robot_bodies},
        contact_box_m={name: touches.box_m.get(name, nan) for name in touches.box_bodies},
    )
