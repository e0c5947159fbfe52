"""One closed-loop run of a validated scenario, in steps: build (robot, simulation, MPCs), simulate, summarise,
plot. Whatever happens, the run directory keeps steps.csv, summary.json (status, and why it failed or was
interrupted), meta.json and run.log, as far as the disk lets them be written (summary.json whole or not at all);
steps.jsonl streams the steps during the run, for a run killed hard."""

from __future__ import annotations

import json
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

from harmony_cli.console import warn
from harmony_cli.experiment.actuation import Actuator
from harmony_cli.experiment.faults import HeldPlans, RunFault, Writes, failed, fault_of
from harmony_cli.experiment.figure_process import figure_processes
from harmony_cli.experiment.health import Health, check_start
from harmony_cli.experiment.interrupts import (
    Guard,
    RunInterrupted,
    RunTimedOut,
    interrupted_summary,
    signals_end_the_run,
    steps_so_far,
)
from harmony_cli.experiment.loop import Watch, run_loop
from harmony_cli.experiment.replay_log import ReplayLog
from harmony_cli.experiment.results import RunRecord, finish_run
from harmony_cli.experiment.run_dir import machine_meta
from harmony_cli.experiment.sensing import Sensors
from harmony_cli.experiment.stream import STREAM, StepStream
from harmony_cli.experiment.task_watch import TaskWatch
from harmony_cli.mpc.wholebody import WholeBodyMPC
from harmony_cli.planning.planner import Planner
from harmony_cli.planning.stance_check import unposed
from harmony_cli.robot.model import Robot
from harmony_cli.scenario import Scenario, robot_of, robot_warnings
from harmony_cli.sim.engine import Simulator, open_simulator
from harmony_cli.sim.video import VideoRecorder, frame_every
from harmony_cli.tasks.motion import Predictor
from harmony_cli.tasks.obstacle_estimate import ObstacleTracks
from harmony_cli.tasks.reference import HandReference, TrajectoryReferences
from harmony_cli.tasks.scene_check import SceneCheck
from harmony_cli.tasks.targets import References

if TYPE_CHECKING:
    import pandas as pd

REUSED = "its structure built by an earlier run in this process"  # run.log (mpc/structures.py)
VIDEO_FPS, VIDEO_SIZE = 10.0, (480, 360)  # TinyRenderer: ~0.1 s per frame at this size on a 2-core VM


class RunFailed(RuntimeError):
    """A run that stopped part-way; its directory holds steps.csv, run.log and summary.json (status, error)."""

    def __init__(self, run_dir: Path, reason: str):
        super().__init__(f"{reason} (logs and status in {run_dir})")
        self.run_dir = run_dir


@dataclass
class Built:
    """What a run builds once, before its first control step."""

    robot: Robot
    mpc: WholeBodyMPC
    sim: Simulator
    references: References
    watch: Watch | None
    predict: Predictor | None
    sensors: Sensors
    actuator: Actuator


def build(scenario: Scenario, scenario_dir: Path) -> Built:
    """The simulation first: a robot that starts inside the ground or an obstacle is refused before the MPCs'
    build (RunFault "penetration"), and so is a task with a hand target beyond the arms' reach or behind a gap the
    base cannot pass (RunFault "impossible": a proof from geometry). A blocked stance for which the controller's
    search finds no base pose ends the run there too, as the controller's failure (RunFault "no stance")."""
    robot = robot_of(scenario, scenario_dir)
    sim = open_simulator(robot, scenario.sim, scenario.world, scenario.pushes)
    try:
        check_start(sim.penetrations())
        if (why := SceneCheck(scenario_dir).unreachable(scenario)) is not None:
            raise RunFault("impossible", f"the scene has no solution before the robot moves: {why}")
        if scenario.task is not None and (why := unposed(scenario, robot)) is not None:
            raise RunFault("no stance", f"the controller found no stance before the robot moved: {why}")
        mpc = WholeBodyMPC(robot, scenario, scenario.sim.control_dt)
        mpc.prepare(sim.observe().q)  # its first step's structures, before the loop's clock starts
    except BaseException:
        sim.close()
        raise
    obstacles, noise = scenario.world.obstacles, scenario.sensing.noise.obstacle_position.std
    tracks = ObstacleTracks(obstacles, noise, scenario.sim.control_dt)
    sensors = Sensors(sim, scenario.sensing, robot, scenario.sim.control_dt, scenario.seed, tracks)
    actuator = Actuator(sim, scenario.control.latency, scenario.sim.physics_dt)
    predict = tracks.predictor() if any(o.motion is not None for o in obstacles) else None
    if scenario.task is not None:
        references = Planner(robot, scenario, [tracks.motion(i) for i in range(len(obstacles))] if tracks else None)
        return Built(robot, mpc, sim, references, TaskWatch(references), predict, sensors, actuator)
    if scenario.reference is None:  # validation leaves exactly one of task / reference
        raise ValueError(f"{scenario.name}: neither a task nor a reference")
    reference = HandReference(scenario.reference, robot.hand_poses_numeric(robot.home))
    return Built(robot, mpc, sim, TrajectoryReferences(reference), None, predict, sensors, actuator)


def describe(scenario: Scenario, built: Built) -> dict:
    """The summary's description of what was built."""
    mpc = built.mpc
    return {
        "transcription": scenario.mpc.transcription,
        "knots": scenario.mpc.knots,
        "control_points": scenario.mpc.control_points if scenario.mpc.transcription == "bezier" else None,
        "horizon_s": scenario.mpc.horizon,
        "solver": scenario.solver.name,
        "decision_variables": mpc.problem.n_vars,
        "decision_label": mpc.transcription.decision_label,
        "n_dof": built.robot.n_dof,
        "build_time_s": mpc.build_time,
        "task_warning": "; ".join(task_warnings(built)) or None,
    }


def _notes(scenario: Scenario, scenario_dir: Path, built: Built, progress: bool, paths: dict[str, str]) -> list[str]:
    """What run.log says before the loop: the robot's and the simulation's notes, the written task's warnings
    (on the console too when it shows progress: before the robot moves; a study says them in its report), the
    whole-body MPC's size and build time, and each solver's code path (`paths`)."""
    written = task_warnings(built)
    if progress:
        warn(written)
    notes = robot_warnings(scenario, scenario_dir) + list(built.robot.notes) + built.sim.notes
    mpc = built.mpc
    build = f"built whole-body MPC: {mpc.problem.n_vars} decision variables in {mpc.build_time:.2f} s"
    build += f" ({REUSED})" if mpc.reused else ""
    return notes + [f"warning: {line}" for line in written] + [build] + [f"{k}: {v}" for k, v in paths.items()]


def task_warnings(built: Built) -> list[str]:
    """A line each: written grip and place stances that leave the base inside a margin (planning/stance.py), hand
    targets above what the arms reach together (robot/reach.py), free-handed goals inside a margin (clear_goal.py)."""
    if not isinstance(built.references, Planner):
        return []
    stances = [w for stance in built.references.stances if (w := stance.warning()) is not None]
    return stances + built.references.warnings


def solver_paths(built: Built) -> dict[str, str]:
    """The code path each MPC's solver takes (meta.json): a run's speed depends on it."""
    paths = {"whole_body_mpc": built.mpc.solver.path}
    if isinstance(built.references, Planner):
        paths["planner"] = built.references.planner.sqp.path
    return paths


def simulate(
    built: Built,
    scenario: Scenario,
    rows: list[dict],
    stream: StepStream,
    log: IO[str],
    recorder: VideoRecorder | None,
    progress: bool,
    replay: ReplayLog | None = None,
    guard: Guard | None = None,
) -> float:
    """The closed loop, every step's record appended to `rows` and streamed to steps.jsonl as it exists; returns
    the wall time [s]. `guard` is checked every step (a signal whose exception a library swallowed)."""
    every = frame_every(scenario.sim.control_dt, VIDEO_FPS)
    held = HeldPlans()

    def record(row: dict) -> None:
        rows.append(row)
        stream.add(row)
        if not row["success"]:
            log.write(f"t={row['t']:.2f}s: solve failed ({row['status']}); held the last good plan\n")
            log.flush()
        if row.get("planner_success") is False:
            log.write(f"t={row['t']:.2f}s: planner failed ({row['planner_status']}); held its last plan\n")
        held.update(row)  # failing for too long: RunFault
        if recorder and row["step"] % every == 0:
            recorder.capture()

    sim = scenario.sim
    with _progress_bar(scenario.name, progress) as bar:
        task = bar.add_task("run", total=int(round(sim.duration / sim.control_dt)))

        def step_done(done: int, total: int) -> None:  # the total grows while a task's phases wait
            if guard is not None:
                guard.check()
            bar.update(task, completed=done, total=total)

        start = time.perf_counter()
        run_loop(
            built.mpc,
            built.sim,
            built.references,
            sim.duration,
            sim.control_dt,
            sim.substeps,
            record,
            step_done,
            built.watch,
            built.predict,
            Health(built.robot, sim.control_dt),
            replay,
            built.sensors,
            built.actuator,
        )
    return time.perf_counter() - start


def _progress_bar(name: str, shown: bool) -> Progress:
    """The run's progress bar on the console (not `shown`: none)."""
    columns = (TextColumn(f"[bold]{name}"), BarColumn(), TextColumn("{task.completed}/{task.total}"))
    return Progress(*columns, TimeRemainingColumn(), disable=not shown, transient=False)


def _recorder(built: Built, video: Path | None) -> VideoRecorder | None:
    if video is None:
        return None
    base = list(built.robot.base_joints[:2])
    follow = lambda: np.array([*built.sim.observe().q[base], 0.6])
    return VideoRecorder(video, built.sim.camera(VIDEO_SIZE, follow), fps=VIDEO_FPS)


def _stopped(exc: RunInterrupted, rows: list[dict]) -> dict:
    """summary.json's fields for a run stopped by a signal (interrupted) or by its wall-time limit (failed)."""
    if isinstance(exc, RunTimedOut):
        return failed("timeout", f"its wall-time limit was reached; stopped {steps_so_far(rows)}")
    return interrupted_summary(exc, rows)


def _stopped_line(summary: dict) -> str:
    """run.log's line for a stopped run: its reason, as a failure's when it failed (the wall-time limit)."""
    failure = summary.get("failure")
    return f"run failed ({failure}): {summary['reason']}" if failure else summary["reason"]


def execute(
    scenario: Scenario,
    scenario_dir: Path,
    out: Path,
    progress: bool = True,
    concurrency: int = 1,
    video: Path | None = None,
    twin: pd.DataFrame | None = None,
    twin_info: dict | None = None,
    plots: str = "all",
) -> Path:
    """Build, simulate, summarise and plot one run into `out` (its inputs already written there)."""
    meta = machine_meta(concurrency) | {"seed": scenario.seed}
    summary: dict = {"name": scenario.name, "status": "running"} | ({"push_free_twin": twin_info} if twin_info else {})
    rows: list[dict] = []
    replay = ReplayLog()
    built, recorder, writes = None, None, Writes(out, summary)
    log, stream = (out / "run.log").open("w"), StepStream(out / STREAM)
    figures = figure_processes(plots, concurrency, scenario.sim.duration)  # they import while the run builds
    with signals_end_the_run() as guard:
        try:
            built = build(scenario, scenario_dir)
            summary |= describe(scenario, built)
            meta["solver_paths"] = solver_paths(built)
            (out / "meta.json").write_text(json.dumps(meta, indent=2))  # now too: `harmony summarise` after a kill
            notes = _notes(scenario, scenario_dir, built, progress, meta["solver_paths"])
            log.write("".join(f"{line}\n" for line in notes))
            log.flush()
            recorder = _recorder(built, video)
            summary["wall_time_s"] = simulate(built, scenario, rows, stream, log, recorder, progress, replay, guard)
            summary["status"] = "completed"
        except RunInterrupted as exc:  # a signal: the steps so far are results; the wall-time limit: a failure
            summary |= _stopped(exc, rows)
            writes("run.log", lambda: log.write(f"{_stopped_line(summary)}\n"))
            if isinstance(exc, RunTimedOut):
                raise RunFailed(out, summary["reason"]) from exc
            exc.run_dir = out
            raise
        except BaseException as exc:  # noqa: BLE001 - record why, then report
            category, reason = fault_of(exc, out, rows, built.sim if built else None)
            summary |= failed(category, reason)
            # a fault we know says all in its reason; anything else keeps its traceback (in run.log only)
            detail = traceback.format_exc() if category == "error" else f"run failed ({category}): {reason}\n"
            writes("run.log", lambda: log.write(detail))
            if not isinstance(exc, Exception):
                raise
            raise RunFailed(out, reason) from exc
        finally:
            guard.hold()  # a second signal must not cut the results short
            if built is not None:
                built.sim.close()
            run = RunRecord(out, scenario, scenario_dir, rows, summary, meta, twin, replay)
            finish_run(run, (log, stream, recorder), writes, plots, figures)
    if writes.reason is not None:  # the run completed, its results could not all be written
        raise RunFailed(out, writes.reason)
    return out
