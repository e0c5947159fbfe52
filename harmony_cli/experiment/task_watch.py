"""What the log records of a task beyond the loop: each hand's distance to its phase goal, the box from ground
truth (held, touching the robot, tilted, turned against the pads, dropped) and the hands' shear across the pads.
Outside the timed loop; never seen by a controller."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.rotations import grip_shear, off_square_deg, pad_axis, quaternion_matrices
from harmony_cli.planning.planner import Planner
from harmony_cli.robot.observation import Observation
from harmony_cli.sim.truth import Truth

DROP_AFTER = 0.1  # [s] a held box without any contact with the robot for this long: dropped


class TaskWatch:
    def __init__(self, references: Planner):
        self.references = references
        self.dropped_at: float | None = None
        self.loose_since: float | None = None

    def __call__(self, t: float, obs: Observation, truth: Truth) -> dict:
        """Goal errors and the box's state (drop: a held box touching no robot link for DROP_AFTER)."""
        schedule = self.references.schedule
        row = {
            f"{name}_goal_error_m": float(np.linalg.norm(obs.hand_positions[h] - self.references.goal[h]))
            for h, name in enumerate(schedule.hand_names)
        }
        if truth.box_position is None or truth.box_z_axis is None:
            return row
        holding, centre, touching = schedule.holding(t), truth.box_position, truth.box_touches_robot
        if touching or not holding:
            self.loose_since = None
        elif self.loose_since is None:
            self.loose_since = t
        if self.loose_since is not None and t - self.loose_since >= DROP_AFTER and self.dropped_at is None:
            self.dropped_at = t
        tilt = float(np.degrees(np.arccos(np.clip(truth.box_z_axis[2], -1, 1))))
        if truth.box_pose is not None and len(obs.hand_positions) == 2:  # the box against the pads (e_z: normal)
            axis = pad_axis(obs.hand_rotations[:, :, 2])
            row["box_off_square_deg"] = off_square_deg(quaternion_matrices(truth.box_pose[3:7])[0][:, 0], axis)
            row["grip_shear_m"] = grip_shear(obs.hand_positions, axis)
        return row | {
            "box_x": centre[0],
            "box_y": centre[1],
            "box_z": centre[2],
            "box_tilt_deg": tilt,
            "box_from_hands_m": float(np.linalg.norm(centre - obs.hand_positions.mean(axis=0))),
            "box_touches_robot": touching,
            # the box against the robot other than by the pads (an arm, the chest): the force and the links
            "box_on_robot_N": truth.pad_contacts.other_N if truth.pad_contacts is not None else 0.0,
            "box_on_robot_links": " ".join(truth.box_on_links),
            "dropped": self.dropped_at is not None,
        }
