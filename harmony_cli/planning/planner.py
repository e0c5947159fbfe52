"""The first of the two MPCs in series: phase schedule -> task-space planner -> hand references at the whole-body
MPC's knots. It sees only the observation (hands, box pose) and the scenario's static scene."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.rotations import heading_of
from harmony_cli.maths.shapes import table_shape, table_top_pose
from harmony_cli.planning.clear_goal import FARTHEST, cleared
from harmony_cli.planning.grip_force import grip_of, grip_width
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Motion, Outcome, PlannerResult, planned_obstacles
from harmony_cli.planning.hand_sqp import rate_bounds
from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.planning.plan_seed import Ground
from harmony_cli.planning.stance_check import base_bodies, home_hands, no_pose, written_stances
from harmony_cli.planning.stance_plan import NEAR, ChestRamp, stalled_posture, stance_plan
from harmony_cli.planning.stance_pose import STARTS
from harmony_cli.robot.model import Robot
from harmony_cli.robot.observation import Observation
from harmony_cli.robot.reach import hand_ceiling
from harmony_cli.tasks.as_written import target_position
from harmony_cli.tasks.passage import narrowest_width
from harmony_cli.tasks.schedule import ActivePhase, Schedule
from harmony_cli.tasks.targets import HandTargets

if TYPE_CHECKING:
    from harmony_cli.scenario.models import Scenario

LATE_RAMP = 1.0  # [s] a waiting phase's task weight ramps in over this (no jump in a held box's pad forces)


class Planner:
    """Re-plans every `planner.period` control steps and samples the plan at t + knot times."""

    def __init__(self, robot: Robot, scenario: Scenario, motions: list[Motion] | None = None):
        if scenario.task is None:
            raise ValueError(f"{scenario.name}: no task phases to plan for")
        self.scenario = scenario
        self.schedule = Schedule(scenario.task, robot.hand_names, scenario.admittance)
        self.home_rotations = np.array([r for _, r in robot.hand_poses_numeric(robot.home)])
        hands, offset = home_hands(robot)  # home heading is 0 (base yaw 0 at home)
        # `motions`: per obstacle, what predicts it (absolute times -> centres); None: the scripted motions
        obstacles = planned_obstacles(scenario.world.obstacles, scenario.planner.hand_radius, motions)
        base, ground = _footprint(scenario, robot.home[list(robot.base_joints)], hands, motions)
        width = grip_width(scenario, robot, hands)
        self.ceiling = hand_ceiling(robot, width)
        self.warnings = _above(scenario, robot.hand_names, self.ceiling, width)
        self.planner = HandMPC(scenario.planner, obstacles, self.home_rotations, offset, ground, base, self.ceiling)
        self.warnings += self._goals_inside(robot.hand_names)
        self.stances = written_stances(scenario, robot, hands, offset)
        self.stance_plan = stance_plan(scenario, robot, self.stances, offset)  # vias and chest postures
        self.late: set[int] = set()  # the phases that have waited for their goal (and re-planned once)
        self.warnings += [
            f"{no_pose(stance, bool(scenario.robot.trunk), len(STARTS))}: the robot may not get there"
            for stance in self.stance_plan.unplaced
        ]
        self.chest = [robot.index(j) for j in scenario.robot.chest_joints]
        self.robot, self.heading_offset, self.base_pose = robot, offset, list(robot.base_joints)
        self.restanced: set[int] = set()  # the phases that stalled and searched a stance of their own (once each)
        # the chest turns no faster than the hands, and slower under a held box
        self.chest_ramp = ChestRamp(scenario.planner.max_yaw_rate, scenario.planner.held_chest_rate)
        self.table_poses = {t.name: table_top_pose(t) for t in scenario.world.tables}
        box = scenario.world.box
        self.box_radius = 0.5 * float(np.hypot(box.size[0], box.size[1])) if box else None
        self.box_drop: float | None = None  # the box's bottom below the hands' midpoint, measured at the grasp
        self.grip = grip_of(scenario, width)
        self.rates = rate_bounds(scenario.planner)  # the hands' speed and acceleration bounds, box held or not
        self.phase: ActivePhase | None = None
        self.goal = np.zeros(0)  # hand goals of the current phase (hands, 3)
        self.result: PlannerResult | None = None
        self.step_count = 0

    def plan(self, t: float, obs: Observation, knot_times: np.ndarray) -> HandTargets:
        restanced = False
        if self.phase is not None:  # a phase whose goal is not reached waits (schedule.py)
            error = float(np.linalg.norm(obs.hand_positions - self.goal, axis=1).max())
            dt = self.scenario.sim.control_dt
            stalled = self.schedule.stalled(t, dt, error)
            if stalled is not None and stalled not in self.restanced:
                restanced = self._recover(t, obs)
            self.schedule.wait(t, dt, error)
        active = self.schedule.at(t)
        replanned = False
        if self.phase is None or active.index != self.phase.index:
            self.phase, self.goal = active, self._goal(t, obs, active)
            self.planner.via = self.stance_plan.vias.get(active.index)
        elif self.schedule.waited[active.index] > 0.0 and active.index not in self.late:
            replanned = self._replan_late(t, obs, active)
        holding = self.schedule.holding(t)
        log = {
            "phase": active.spec.name,
            "phase_index": active.index,
            "holding": holding,
            "delay_s": self.schedule.delay,
            "replanned": replanned,
            "restanced": restanced,
        }
        # what the hands were asked to be at now (the plan restarts from the measurement)
        now = None if self.result is None else self.result.plan.sample(np.array([t]))[0][0]
        result = self.result
        if self.step_count % self.scenario.planner.period == 0 or result is None or replanned or restanced:
            result = self.result = self._replan(t, obs, active, holding)
            log |= {
                "planner_ms": 1e3 * result.solve_time,
                "planner_status": result.status,
                "planner_success": result.success,
                "planner_iterations": result.iterations,
                "planner_clearance_m": result.min_clearance,
            }
        self.step_count += 1
        positions, rotations = result.plan.sample(t + knot_times)
        force_ref = None
        if self.schedule.admittance.enabled:
            force_ref = np.tile(self.schedule.force(t + knot_times), (len(self.schedule.hand_names), 1))
            if self.grip is not None:
                force_ref = self.grip(force_ref, obs.wrenches, holding)
                log |= {"grip_friction_used": self.grip.friction_used, "carry_pace": self.grip.pace}
        base, posture = obs.q[self.base_pose[:2]], self.stance_plan.posture(active.index)  # base: x, y
        target = None if posture is None or not self.chest else posture.chest(positions, base)  # None: straight
        chest_ref = self.chest_ramp(target, t, knot_times, obs.q[self.chest], holding)
        # the base's stance only where its cost is on (mpc.weights.stance): nothing to compute each step otherwise
        pull = self.scenario.mpc.weights.stance > 0.0
        stance = posture.stance(positions, base) if pull and posture is not None else None
        reliefs = self.stance_plan.reliefs.get(active.index)
        now = positions[0] if now is None else now
        task_weight = self._task_weight(active.index)
        log["task_weight"] = task_weight
        return HandTargets(positions, rotations, now, force_ref, chest_ref, stance, reliefs, task_weight, log)

    def _task_weight(self, phase: int) -> float:
        """The whole-body MPC's multiplier of the hands' tracking weights: 1, or for a phase waiting for its goal,
        ramped up to `mpc.weights.late_task` over its wait's first LATE_RAMP seconds. The posture, symmetry and
        chest costs resolve the arms' redundancy; a hand held off its goal by them is a task they should yield
        to, while a phase that arrives on time is tracked as tuned."""
        waited = float(self.schedule.waited[phase])
        if waited <= 0.0:
            return 1.0
        return 1.0 + (self.scenario.mpc.weights.late_task - 1.0) * min(1.0, waited / LATE_RAMP)

    def _goal(self, t: float, obs: Observation, active: ActivePhase) -> np.ndarray:
        """The hands' goal (hands, 3) of `active` from the observation: box-relative targets where the box is, a held
        grip at its measured width, a free-handed goal out of the obstacles' margins."""
        poses = dict(self.table_poses)
        if obs.box_position is not None:
            poses["box"] = (obs.box_position, obs.box_yaw)
        goal = self.schedule.goal(active.spec, obs.hand_positions, poses)
        if self.schedule.holding(t) and active.spec.force > 0.0:  # the grip's width is what the pads stand at
            goal = _at_width(goal, float(np.linalg.norm(obs.hand_positions[1] - obs.hand_positions[0])))
        if self._free_handed(goal, obs.box_position, t):
            goal = cleared(goal, self.planner.obstacles)[0]  # said before the run: _goals_inside
        return goal

    def _replan_late(self, t: float, obs: Observation, active: ActivePhase) -> bool:
        """Once per phase, when it starts waiting for its goal and the box is not held: its goal taken again from
        the observation (a grip's from where the box is now) and a fresh plan (the phase's first plan's search)
        instead of the last one carried on; whether it re-planned. A held box keeps its plan: the pads' force
        follows millimetres of the hands' reference, and a new plan moves it by that much. A phase that then waits
        its whole wait in vain has stalled: the run fails (report/task_failure.py)."""
        self.late.add(active.index)
        if self.schedule.holding(t):
            return False
        self.goal = self._goal(t, obs, active)
        self.planner.phase = None
        return True

    def _recover(self, t: float, obs: Observation) -> bool:
        """The phase at t, as it would give up stalled: a stance for its goal as it is now (stalled_posture) and,
        when one is found, its chest posture and reliefs, a fresh plan and the phase's wait again; whether found."""
        active = self.schedule.at(t)
        self.restanced.add(active.index)
        goal = self._goal(t, obs, active)
        base = obs.q[self.base_pose]
        found = stalled_posture(self.scenario, self.robot, active.index, goal, self.heading_offset, base)
        if found is None:
            return False
        self.stance_plan = self.stance_plan.recovered(*found)
        self.goal, self.planner.phase = goal, None
        self.schedule.retry(active.index)
        return True

    def _free_handed(self, goal: np.ndarray, box: np.ndarray | None, t: float) -> bool:
        """Whether a phase starting at `t` with the hands' `goal` (hands, 3) neither holds the box nor works at it
        (within NEAR of the `box` position, plan view): an approach, a retreat, whose goal may move (clear_goal.py)."""
        at_box = box is not None and float(np.hypot(*(goal.mean(axis=0) - box)[:2])) <= NEAR
        return not at_box and not self.schedule.holding(t)

    def _goals_inside(self, hand_names: tuple[str, ...]) -> list[str]:
        """A line per free-handed phase whose written goal (the box where it starts) is inside an obstacle's
        margin: how far its goal moves to clear it."""
        assert self.scenario.task is not None
        box = self.scenario.world.box
        lines = []
        starts = np.r_[0.0, self.schedule.ends[:-1]]
        for phase, start in zip(self.scenario.task.phases, starts):
            written = [target_position(phase.hands.get(h), self.scenario) for h in hand_names]
            if any(g is None for g in written):
                continue
            goal = np.array(written)
            if not self._free_handed(goal, None if box is None else np.asarray(box.position), float(start)):
                continue
            _, by, inside = cleared(goal, self.planner.obstacles)
            if inside is not None:
                fix = f"it moves {by:.2f} m to clear it" if by > 0 else f"no shift up to {FARTHEST:g} m clears it"
                name = self.scenario.world.obstacles[inside].name
                lines.append(f"goal: phase {phase.name}'s hand goal is inside obstacle {name}'s margin; {fix}")
        return lines

    @property
    def delay(self) -> float:
        """[s] how long the phases have waited for their goals: the run lasts this much longer."""
        return self.schedule.delay

    def _replan(self, t: float, obs: Observation, active: ActivePhase, holding: bool) -> PlannerResult:
        """The planner's new plan from the measured hands, within the rate bounds of the moment (a held box's: the
        grip's); an exception is a failed solve that holds the last plan (none yet: raised)."""
        start = time.perf_counter()
        try:
            heading = heading_of(obs.hand_rotations, self.home_rotations)
            if self.scenario.planner.start_velocity == "plan" and self.result is not None:
                rates = self.result.plan.rates(t)  # measured pose, the plan's own velocity: no restart at rest
                state = HandState(obs.hand_positions, rates[:6].reshape(2, 3), heading, rates[6])
            else:
                state = HandState(obs.hand_positions, obs.hand_velocities, heading, obs.heading_rate)
            speeds, accelerations = self.rates
            if holding and self.grip is not None and active.spec.force > 0.0:
                speeds, accelerations = self.grip.bounds(speeds, accelerations, active.spec.force)
            self.planner.sqp.set_bounds(speeds, accelerations)
            box = self.scenario.world.box
            if holding and self.box_drop is None and box is not None and obs.box_position is not None:
                self.box_drop = obs.hand_positions[:, 2].mean() - (obs.box_position[2] - box.size[2] / 2)
            radius = self.box_radius if holding else None
            return self.planner.step(t, state, self.goal, active.end, active.index, radius, self.box_drop or 0.0)
        except Exception as exc:  # noqa: BLE001 - a QP's or our numerics' error: like a failed solve
            if self.result is None:
                raise
            message = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            detail = f"{type(exc).__name__}: {message}"[:200]
            elapsed = time.perf_counter() - start
            return PlannerResult(self.result.plan, Outcome.ERROR, 0, elapsed, float("nan"), detail=detail)


def _at_width(goal: np.ndarray, width: float) -> np.ndarray:
    """The two hands' `goal` (2, 3) moved along the line between them, about their midpoint, to `width` [m] apart.

    While a box is held by a squeeze force the pads stand inside the faces the written targets touch, by as much
    as the pads and the box give under that force: the width across the grip is the force loop's. A phase that
    starts with the box held keeps the width measured at its start, so that its plan does not pull the pads back
    towards the written faces, against the admittance (the contacts are stiff: a fraction of a millimetre is a
    large share of the squeeze)."""
    middle, apart = goal.mean(axis=0), goal[1] - goal[0]
    return middle + np.outer([-0.5, 0.5], apart * (width / float(np.linalg.norm(apart))))


def _above(scenario: Scenario, hand_names: tuple[str, ...], ceiling: float | None, width: float) -> list[str]:
    """A line per phase whose written hand targets are above the `ceiling` (+1 cm)."""
    if ceiling is None or scenario.task is None:
        return []
    lines = []
    for phase in scenario.task.phases:
        heights = [
            (float(z[2]), h) for h in hand_names if (z := target_position(phase.hands.get(h), scenario)) is not None
        ]
        if heights and (top := max(heights, key=lambda pair: pair[0]))[0] > ceiling + 0.01:
            lines.append(
                f"reach: phase {phase.name} asks the {top[1]} hand at z = {top[0]:.3f} m, above the {ceiling:.3f} m "
                f"both hands reach together with the pads level ({width:.3f} m apart): the plan stays below it"
            )
    return lines


def _footprint(
    scenario: Scenario, base_pose: np.ndarray, hands: np.ndarray, motions: list[Motion] | None
) -> tuple[PlannedBase | None, Ground | None]:
    """The footprint as the planner carries it behind the hands (None: no footprint, or nothing to clear), and the
    tables and the base's half width at its narrowest for the planner's route, which is the base's where the
    planner carries the footprint (None: no footprint)."""
    circles = np.asarray(scenario.robot.footprint, dtype=float).reshape(-1, 3)
    if len(circles) == 0:
        return None, None
    bodies, _ = base_bodies(scenario, motions)
    tables = [(table_shape(t), scenario.robot.base_margin) for t in scenario.world.tables]
    if not bodies:
        return None, Ground(tables, 0.5 * narrowest_width(circles))
    base = PlannedBase.at_home(circles, base_pose, hands, bodies)
    return base, Ground(tables, 0.5 * narrowest_width(circles), base.offsets.mean(axis=0), base.yaw_home)
