"""The closed loop: observe -> references at the knots -> whole-body MPC -> command -> physics -> log."""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from harmony_cli.experiment.actuation import Actuator
from harmony_cli.experiment.faults import RunFault
from harmony_cli.experiment.health import Health
from harmony_cli.experiment.memory import reserve_heap
from harmony_cli.experiment.replay_log import ReplayLog
from harmony_cli.experiment.sensing import Sensors
from harmony_cli.experiment.step_log import step_record
from harmony_cli.mpc.knot_params import hand_rows
from harmony_cli.mpc.wholebody import Command, WholeBodyMPC
from harmony_cli.robot.observation import Observation
from harmony_cli.sim.engine import Simulator
from harmony_cli.sim.truth import Truth
from harmony_cli.tasks.motion import Predictor
from harmony_cli.tasks.targets import HandTargets, References

Watch = Callable[[float, Observation, Truth], dict]  # logged fields from ground truth (e.g. the box: dropped?)
FREEZE_EVERY = 50  # steps between moving what survived (the records) out of the garbage collector's scans


def run_loop(
    mpc: WholeBodyMPC,
    sim: Simulator,
    references: References,
    duration: float,
    control_dt: float,
    substeps: int,
    record: Callable[[dict], None],
    on_step: Callable[[int, int], None] = lambda i, n: None,
    watch: Watch | None = None,
    predict: Predictor | None = None,
    health: Health | None = None,
    replay: ReplayLog | None = None,
    sensors: Sensors | None = None,
    actuator: Actuator | None = None,
) -> None:
    """Run the whole scenario; every step's record goes to `record` as soon as it exists (nothing is lost).

    `loop_ms`: wall time from the observation to the command (references, obstacle prediction, whole-body MPC);
    the record (ground truth, `watch`, cost terms, _breakdown) is built outside it. `predict`: the moving obstacles'
    centres at t + the knot times. `health` checks each measurement (after its record) before its command. `replay`
    gets the knots and the plan. `sensors` (noise, delay, estimated obstacles) and `actuator` (latency) stand
    between the controllers and `sim`; without them the controllers see its state and their commands act at once."""
    n_steps = lambda: int(round((duration + references.delay) / control_dt))  # a task's waits lengthen the run
    step, previous = 0, {"physics_ms": 0.0, "log_ms": 0.0, "replay_ms": 0.0}  # the step before's, after its record
    observe, actuator = (sensors.observe if sensors else lambda t: sim.observe()), actuator or Actuator(sim, 0, 1)
    with collector_frozen():
        while step < n_steps():
            t = step * control_dt
            sensed = time.perf_counter()
            obs = observe(t)  # the MPC always starts from the measured state
            start = time.perf_counter()
            targets = references.plan(t, obs, mpc.knot_times)
            if predict is not None:
                mpc.set_obstacle_centres(predict(t + mpc.knot_times))
            mpc.set_reliefs(targets.reliefs)
            solve = time.perf_counter()
            hands = hand_rows(targets.positions, targets.rotations)
            command, result = mpc.step(
                obs.q, hands, targets.force_ref, obs.pad_forces, targets.chest_ref, targets.stance, targets.task_weight
            )
            end = time.perf_counter()
            truth = sim.truth()
            watched = (watch(t, obs, truth) if watch else {}) | (sensors.log(t) if sensors else {})
            delay = actuator.delay(end - sensed)  # physics steps before the command acts
            timing = _breakdown((sensed, start, solve, end), result, previous) | actuator.log(delay)
            record(
                step_record(step, t, 1e3 * (end - start), mpc, obs, targets, command, result, truth, watched | timing)
            )
            replay_ms = _log_replay(replay, mpc, targets, references, truth)
            if health is not None:
                health.check(t, obs.q, obs.hand_positions, targets.now)
            _check_finite(command, t, result.status)
            _freeze_survivors(step)
            physics = time.perf_counter()
            actuator.send(command.q, command.qd, substeps, delay)
            physics_ms, log_ms = 1e3 * (time.perf_counter() - physics), 1e3 * (physics - end) - replay_ms
            previous = {"physics_ms": physics_ms, "log_ms": log_ms, "replay_ms": replay_ms}
            step += 1
            on_step(step, n_steps())


def _breakdown(times: tuple[float, ...], result, previous: dict[str, float]) -> dict:
    """A record's breakdown of its step, from the clock `times` (sensing, planning, solving and the command's):
    `sense_ms`, `planner_ms` (if any, from the planner's log), `wbmpc_ms`, `qp_rows`, `qp_solves`, and the step
    before's `previous_log_ms` (truth, record, health), `previous_physics_ms` (command and physics) and
    `previous_replay_ms` (replay.npz), which come after its record."""
    sensed, start, solve, end = times
    timing = {"sense_ms": 1e3 * (start - sensed), "wbmpc_ms": 1e3 * (end - solve), "qp_rows": result.qp_rows}
    return timing | {"qp_solves": result.qp_solves} | {f"previous_{k}": v for k, v in previous.items()}


def _log_replay(
    replay: ReplayLog | None, mpc: WholeBodyMPC, targets: HandTargets, references: References, truth: Truth
) -> float:
    """The step's knots and plan into `replay`; the time it took [ms]."""
    if replay is None:
        return 0.0
    start = time.perf_counter()
    replay.add(mpc, targets, getattr(getattr(references, "result", None), "plan", None), truth)
    return 1e3 * (time.perf_counter() - start)


def _freeze_survivors(step: int) -> None:
    """Every FREEZE_EVERY steps: young garbage collected, the records kept out of later scans."""
    if step % FREEZE_EVERY == FREEZE_EVERY - 1:
        gc.collect(1)
        gc.freeze()


def _check_finite(command: Command, t: float, status: str) -> None:
    """A non-finite command is never sent to the simulator."""
    if not (np.isfinite(command.q).all() and np.isfinite(command.qd).all()):
        raise RunFault("solver", f"a non-finite command at t = {t:.2f} s (whole-body MPC: {status})")


@contextmanager
def collector_frozen() -> Iterator[None]:
    """The set-up's objects out of the garbage collector's scans (a full collection of them pauses tens of ms
    mid-loop), back in when the loop ends however it ends; the heap reserved before it (memory.py)."""
    reserve_heap()
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
