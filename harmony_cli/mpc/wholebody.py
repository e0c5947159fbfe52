"""Whole-body MPC (MPC-W): track both hands' poses at K knots with all joints, built once, warm-started."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from harmony_cli.maths.filters import LowPass
from harmony_cli.mpc.clearance import scenario_clearances
from harmony_cli.mpc.problem import NoPlanToHold, SolveResult
from harmony_cli.mpc.solvers import make_solver
from harmony_cli.mpc.structures import structure_for
from harmony_cli.mpc.wholebody_problem import joint_limits
from harmony_cli.robot.model import Robot

if TYPE_CHECKING:
    from harmony_cli.scenario.models import Scenario


@dataclass(frozen=True)
class Command:
    q: np.ndarray  # position targets at t + control_dt
    qd: np.ndarray  # velocity targets (base: mean velocity over the control period)
    held: bool  # True when the solve failed and the last good plan was used
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))  # compliant offsets at t + control_dt [m]


class WholeBodyMPC:
    """Built once per run on a structure built once per process (`reused`: an earlier run's); `step` solves from
    the measured state and reads out the command for the next period."""

    def __init__(self, robot: Robot, scenario: Scenario, control_dt: float):
        start = time.perf_counter()
        self.robot, self.control_dt = robot, control_dt
        self.admittance = scenario.admittance if scenario.admittance.enabled else None
        self.max_acceleration = scenario.mpc.max_acceleration
        self.n_hands = len(robot.end_effectors)
        self.limits = joint_limits(robot, self.admittance)
        structure, self.reused = structure_for(robot, scenario)  # built once per process (mpc/structures.py)
        self.transcription, self.clearances = structure.transcription, structure.clearances
        self.layout, self.problem = structure.layout, structure.problem
        _, poses = scenario_clearances(scenario)
        # obstacle poses at every knot (rows of the knot parameters after the hands'); moving ones update them
        self.obstacle_poses = np.tile(poses[:, None], self.transcription.n_knots)
        self._relieved = False  # whether a relief is set (set_reliefs)
        self.solver = make_solver(self.problem, scenario.solver)  # this run's own: QPs, warm starts
        self.problem.compile_terms()  # for the steps log; after the solver's maps, which the first step waits for
        self.build_time = time.perf_counter() - start
        self.x: np.ndarray | None = None  # last good solution
        self.pinned = list(robot.pinned_joints)
        self.force_filter = LowPass(self.admittance.force_filter, control_dt) if self.admittance else None
        self.force_seen = np.zeros(self.n_hands)  # the filtered pad forces the last step's admittance used [N]

    @property
    def knot_times(self) -> np.ndarray:
        return self.transcription.knot_times

    def set_obstacle_centres(self, centres: np.ndarray) -> None:
        """Predicted centres (obstacles, K, 3) of the world's obstacles (scenario order, the first clearances) at
        the knot times of the next `step`; yaws and tables stay as built."""
        for o, at_knots in enumerate(centres):
            self.obstacle_poses[self.layout.pose_centre(o)] = at_knots.T

    def set_reliefs(self, reliefs: np.ndarray | None) -> None:
        """How far the first clearances' margins (the world's obstacles, scenario order) are lowered [m] from the
        next `step` on, each within what it gives (None: none lowered)."""
        if reliefs is None and not self._relieved:
            return
        wanted = np.zeros(len(self.clearances))
        if reliefs is not None:
            wanted[: len(reliefs)] = np.clip(reliefs, 0.0, [c.give for c in self.clearances[: len(reliefs)]])
        for o, relief in enumerate(wanted):
            self.obstacle_poses[self.layout.pose_relief(o)] = relief
        self._relieved = reliefs is not None

    def _constant(self, q_now: np.ndarray) -> np.ndarray:
        t = self.transcription
        positions = np.tile(q_now[:, None], t.position_basis.shape[1]).ravel("F")
        return np.concatenate([positions, np.zeros(t.n_vars - positions.size)])

    def _solve(self, x0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray) -> SolveResult:
        """The solver's result; an exception or a non-finite solution is a failed solve (the last plan is held)."""
        start = time.perf_counter()
        try:
            result = self.solver.solve(x0, lbx, ubx, self.params)
        except Exception as exc:  # noqa: BLE001 - a solver plugin's bug or a numerical error: a failed solve
            status = f"exception {type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else ''}"
            return SolveResult(x0, False, status[:200], 0, time.perf_counter() - start)
        if result.success and not np.all(np.isfinite(result.x)):  # NaN / inf never becomes a plan
            return replace(result, success=False, status="non-finite solution")
        return result

    def step(
        self,
        q_now: np.ndarray,
        hand_ref: np.ndarray,
        force_ref: np.ndarray | None = None,
        force_meas: np.ndarray | None = None,
        chest_ref: np.ndarray | None = None,
        stance: np.ndarray | None = None,
        task_weight: float = 1.0,
    ) -> tuple[Command, SolveResult]:
        """hand_ref: (12 * hands) x K references at the knot times (knot_params.hand_rows); with admittance,
        force_ref: hands x K squeeze force references and force_meas: (hands,) measured pad normal forces [N];
        chest_ref: chest joints x K references of the chest joints' cost (None: 0); stance: 4 x K, the base's
        reference x, y, yaw and its weight at each knot (None: no stance); task_weight: the hands' tracking
        weights' multiplier (knot_params.KnotLayout)."""
        if self.force_filter is not None and force_meas is not None:
            self.force_seen = self.force_filter(force_meas)
        self.params = self.layout.stack(
            hand_ref, self.obstacle_poses, force_ref, self.force_seen, chest_ref, stance, task_weight
        )
        t, dt = self.transcription, self.control_dt
        q_init, lbx, ubx = self._bounds(q_now)
        x0 = self._constant(q_init) if self.x is None else t.shift(self.x, dt)
        if self.max_acceleration is not None and self.x is not None:
            lbx, ubx = self._acceleration_bounds(x0, q_init, lbx, ubx)
        result = self._solve(np.clip(x0, lbx, ubx), lbx, ubx)
        command = self._command(result.x, held=False) if result.success else None
        if command is not None and np.isfinite(command.q).all() and np.isfinite(command.qd).all():
            self.x = result.x
            return command, result
        if command is not None:  # a command the simulator must never get: a failed solve too
            result = replace(result, success=False, status="non-finite command")
        if self.x is None:
            raise NoPlanToHold(f"first whole-body MPC solve failed ({result.status}); no plan to hold")
        # A held plan is read out from its shifted copy: it continues from where it was, not from q_now.
        self.x = t.shift(self.x, dt)
        return self._command(self.x, held=True), result

    def prepare(self, q_now: np.ndarray) -> None:
        """Build what the first `step` from `q_now` would build on first use (its QP, compiled code loaded), before
        the loop's clock starts: the first step costs what a later one does. Nothing it solves changes."""
        self.solver.prepare(*self._bounds(q_now)[1:])

    def _bounds(self, q_now: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(the joints' state the plan starts from, lbx, ubx): the compliant offsets start at 0, mimic joints from
        their leaders (the coupling rows hold the plan to it), pinned joints at home."""
        t, robot = self.transcription, self.robot
        q_init = np.concatenate([robot.coupled(q_now), np.zeros(t.n_dof - q_now.size)])
        q_init[self.pinned] = robot.home[self.pinned]
        return q_init, *t.bounds(*self.limits, q_init, self.pinned, robot.home[self.pinned])

    def _acceleration_bounds(self, x0, q_now, lbx, ubx) -> tuple[np.ndarray, np.ndarray]:
        """The joints' velocity at t = 0 within max_acceleration * dt of the warm start's (the last plan's, now):
        a real-time iteration otherwise answers a jump of the references (a new phase) with a step in the command
        that rings for a few periods (a held box's pads let go). Where a position limit leaves no room, the limit."""
        assert self.max_acceleration is not None
        where, lo, hi = self.transcription.velocity_band(x0, q_now, self.max_acceleration * self.control_dt)
        lower, upper = np.maximum(lbx[where], lo), np.minimum(ubx[where], hi)
        room = (np.arange(lower.size) < self.robot.n_dof) & (lower <= upper)  # the joints, not the compliant offsets
        lbx, ubx = lbx.copy(), ubx.copy()
        lbx[where], ubx[where] = np.where(room, lower, lbx[where]), np.where(room, upper, ubx[where])
        return lbx, ubx

    def _command(self, x: np.ndarray, held: bool) -> Command:
        t, dt, robot = self.transcription, self.control_dt, self.robot
        q_cmd, qd_cmd = t.readout(x, dt)
        base = list(robot.base_joints)  # velocity-commanded: the plan's mean velocity over the period
        qd_cmd[base] = (q_cmd[base] - t.readout(x, 0.0)[0][base]) / dt
        nd = robot.n_dof
        return Command(q_cmd[:nd], qd_cmd[:nd], held, q_cmd[nd:])
