"""The first of the two MPCs in series: phase schedule -> task-space planner -> hand references at the whole-body
MPC's knots; `watch` reports the box (held, dropped) for the log, outside the timed loop."""

from __future__ import annotations

from functools import partial

import numpy as np

from harmony_cli.motion import centre_at
from harmony_cli.planner import HandState, Obstacle, TaskPlanner
from harmony_cli.robot import Robot
from harmony_cli.tasks import Schedule
from harmony_cli.world import obstacle_shape

DROP_AFTER = 0.1  # [s] a held box without any contact with the robot for this long: dropped


def heading_of(rotations: np.ndarray, home_rotations: np.ndarray) -> float:
    """Common heading of the hands: mean yaw of R_h R_h(home)^T."""
    relative = np.einsum("hij,hkj->hik", rotations, home_rotations)
    return float(np.arctan2(relative[:, 1, 0].sum(), relative[:, 0, 0].sum()))


class TaskReferences:
    """Re-plans every `planner.period` control steps and samples the plan at t + knot times."""

    def __init__(self, robot: Robot, scenario, sim):
        self.scenario, self.sim, self.world = scenario, sim, sim.world
        self.schedule = Schedule(scenario.task, robot.hand_names, scenario.admittance)
        poses = robot.hand_poses_numeric(robot.home)
        self.home_rotations = np.array([r for _, r in poses])
        p0, p1 = (p.ravel() for p, _ in poses)
        offset = -np.arctan2(p1[1] - p0[1], p1[0] - p0[0])  # home heading is 0 (base yaw 0 at home)
        obstacles = [Obstacle(obstacle_shape(o), o.margin + scenario.planner.hand_radius,
                              partial(centre_at, o) if o.motion is not None else None)  # the true motion predicts
                     for o in scenario.world.obstacles]
        self.planner = TaskPlanner(scenario.planner, obstacles, self.home_rotations, offset)
        box = scenario.world.box
        self.box_radius = 0.5 * float(np.hypot(box.size[0], box.size[1])) if box else None
        self.box_drop = None  # the box's bottom below the hands' midpoint, measured when the grasp begins
        self.phase, self.goal, self.result, self.step_count = None, None, None, 0
        self.dropped_at, self.loose_since = None, None

    def __call__(self, t: float, obs, knot_times: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
        active = self.schedule.at(t)
        if self.phase is None or active.index != self.phase.index:
            poses = {name: self.world.pose(name) for name in self.world.tables} if self.world else {}
            if self.world and self.world.box is not None:
                poses["box"] = self.world.pose("box")
            self.phase, self.goal = active, self.schedule.goal(active.spec, obs.hand_positions, poses)
        holding = self.schedule.holding(t)
        row = {"phase": active.spec.name, "phase_index": active.index, "holding": holding}
        if self.result is not None:  # what the hands were asked to be at now (the plan restarts from the measurement)
            row["reference_now"] = self.result.plan.sample(np.array([t]))[0][0]
        if self.step_count % self.scenario.planner.period == 0 or self.result is None:
            heading = heading_of(obs.hand_rotations, self.home_rotations)
            if self.scenario.planner.start_velocity == "plan" and self.result is not None:
                rates = self.result.plan.rates(t)  # measured pose, the plan's own velocity: no restart at rest
                state = HandState(obs.hand_positions, rates[:6].reshape(2, 3), heading, rates[6])
            else:
                state = HandState(obs.hand_positions, obs.hand_velocities, heading, obs.heading_rate)
            if holding and self.box_drop is None:
                centre, _ = self.world.box_state()
                self.box_drop = obs.hand_positions[:, 2].mean() - (centre[2] - self.scenario.world.box.size[2] / 2)
            self.result = self.planner.step(t, state, self.goal, active.end, active.index,
                                            self.box_radius if holding else None, self.box_drop or 0.0)
            row |= {"planner_ms": 1e3 * self.result.solve_time, "planner_status": self.result.status,
                    "planner_success": self.result.success, "planner_iterations": self.result.iterations,
                    "planner_clearance_m": self.result.min_clearance}
        self.step_count += 1
        positions, rotations = self.result.plan.sample(t + knot_times)
        if self.schedule.admittance.enabled:
            row["force_ref"] = np.tile(self.schedule.force(t + knot_times), (len(self.schedule.hand_names), 1))
        return positions, rotations, row

    def watch(self, t: float, obs) -> dict:
        """Goal errors and the box's state (drop: a held box touching no robot link for DROP_AFTER)."""
        row = {f"{name}_goal_error_m": float(np.linalg.norm(obs.hand_positions[h] - self.goal[h]))
               for h, name in enumerate(self.schedule.hand_names)}
        if self.world is None or self.world.box is None:
            return row
        holding = self.schedule.holding(t)
        centre, z_axis = self.world.box_state()
        from_hands = float(np.linalg.norm(centre - obs.hand_positions.mean(axis=0)))
        touching = self.world.touching(self.world.box, self.sim.body)
        self.loose_since = None if touching or not holding else (self.loose_since if self.loose_since is not None
                                                                  else t)
        if self.loose_since is not None and t - self.loose_since >= DROP_AFTER and self.dropped_at is None:
            self.dropped_at = t
        return row | {"box_x": centre[0], "box_y": centre[1], "box_z": centre[2], "box_tilt_deg":
                float(np.degrees(np.arccos(np.clip(z_axis[2], -1, 1)))), "box_from_hands_m": from_hands,
                "box_touches_robot": touching, "dropped": self.dropped_at is not None}
