"""`harmony run`: one scenario, closed loop, into a self-describing run directory."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import time
import traceback
from datetime import datetime
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

from harmony_cli.loop import run_loop, trajectory_references
from harmony_cli.metrics import (AFTER_PUSH_S, displacement_from_twin, force_outcome, push_outcome, summarise,
                                 task_outcome)
from harmony_cli.pushes import pushed_hand
from harmony_cli.motion import obstacle_predictor
from harmony_cli.reference import HandReference
from harmony_cli.robot import load_robot
from harmony_cli.scenario import load_scenario, scenario_yaml
from harmony_cli.sim import Simulation
from harmony_cli.two_stage import TaskReferences
from harmony_cli.video import VideoRecorder, frame_every
from harmony_cli.wholebody import WholeBodyMPC

VIDEO_FPS, VIDEO_SIZE = 10.0, (480, 360)  # TinyRenderer: ~0.1 s per frame at this size on a 2-core VM

class RunFailed(RuntimeError):
    """A run that stopped part-way; its directory holds steps.csv, run.log and summary.json (status, error)."""

    def __init__(self, run_dir: Path, reason: str):
        super().__init__(f"{reason} (logs and status in {run_dir})")
        self.run_dir = run_dir


PACKAGES = ("harmony-cli", "casadi", "pyoptas", "pin", "pybullet", "numpy", "pydantic", "pandas")


def _git_sha() -> str:
    here = Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                               capture_output=True, text=True).stdout.strip()
        return (sha + ("-dirty" if dirty else "")) or "unknown"
    except OSError:
        return "unknown"


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_meta(concurrency: int) -> dict:
    versions = {}
    for pkg in PACKAGES:
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = "absent"
    return {"python": platform.python_version(), "packages": versions, "git_sha": _git_sha(), "cpu": _cpu(),
            "cores": os.cpu_count(), "host": platform.node(), "concurrency": concurrency,
            "started": datetime.now().isoformat(timespec="seconds")}


def default_run_dir(name: str, root: Path = Path("results/runs")) -> Path:
    return root / f"{name}-{datetime.now().strftime('%Y%m%d-%H%M%S-%f')}"


def _push_free_twin(path: Path, overrides: list[str], scenario, out: Path, progress: bool,
                    concurrency: int) -> tuple[pd.DataFrame | None, dict]:
    """The same scenario without its pushes, up to the last push's window end, into `out`: the deterministic
    counterfactual each hand's push displacement is measured from (a task's live reference re-plans from the
    measured pose, so the tracking error hides a push)."""
    dt = scenario.sim.control_dt
    until = max(p.start + p.duration for p in scenario.pushes) + AFTER_PUSH_S
    duration = float(min(scenario.sim.duration, dt * np.ceil(until / dt - 1e-9)))
    try:
        run_scenario(path, list(overrides) + ["pushes=[]", f"sim.duration={duration!r}"], out, progress,
                     concurrency, push_free_twin=False)
    except RunFailed as exc:
        return None, {"dir": str(out), "status": "failed", "error": str(exc)}
    return pd.read_csv(out / "steps.csv"), {"dir": str(out), "status": "completed", "duration_s": duration}


def run_scenario(path: str | Path, overrides: list[str] = (), out: Path | None = None, progress: bool = True,
                 concurrency: int = 1, video: Path | bool | None = None, push_free_twin: bool = True) -> Path:
    """Run one scenario closed loop; always leaves steps.csv, summary.json (status) and run.log in `out`;
    `video` (a .mp4 or .gif path, or True for out/video.mp4) records it, rendered headless. A scenario with pushes
    first runs its push-free twin into out/push_free (`push_free_twin=False`: displacements from the reference)."""
    path = Path(path)
    scenario = load_scenario(path, overrides)
    out = Path(out) if out else default_run_dir(scenario.name)
    out.mkdir(parents=True, exist_ok=True)
    video = out / "video.mp4" if video is True else video
    resolved = yaml.safe_load(scenario_yaml(scenario))
    resolved["robot"]["urdf"] = str((path.parent / scenario.robot.urdf).resolve())  # re-runnable from out/
    (out / "scenario.resolved.yaml").write_text(yaml.safe_dump(resolved, sort_keys=False))
    (out / "overrides.yaml").write_text(yaml.safe_dump({"scenario": str(path), "overrides": list(overrides)}))
    meta = machine_meta(concurrency) | {"seed": scenario.seed}
    log = (out / "run.log").open("w")
    rows: list[dict] = []
    summary: dict = {"name": scenario.name, "status": "running"}
    np.random.seed(scenario.seed)  # nothing in the loop is random today; the seed is recorded and fixed
    recorder, twin = None, None
    if scenario.pushes and push_free_twin:
        twin, summary["push_free_twin"] = _push_free_twin(path, list(overrides), scenario, out / "push_free",
                                                          progress, concurrency)
    try:
        robot = load_robot(scenario.robot, path.parent)
        mpc = WholeBodyMPC(robot, scenario, scenario.sim.control_dt)
        sim = Simulation(robot, scenario.sim, scenario.world, scenario.pushes)
        if scenario.task is not None:
            references = TaskReferences(robot, scenario, sim)
            watch = references.watch
        else:
            references = trajectory_references(HandReference(scenario.reference, robot.hand_poses_numeric(robot.home)))
            watch = None
        summary |= {"transcription": scenario.mpc.transcription, "knots": scenario.mpc.knots,
                    "control_points": scenario.mpc.control_points if scenario.mpc.transcription == "bezier" else None,
                    "horizon_s": scenario.mpc.horizon, "solver": scenario.solver.name,
                    "decision_variables": mpc.problem.n_vars, "decision_label": mpc.transcription.decision_label,
                    "n_dof": robot.n_dof, "build_time_s": mpc.build_time}
        log.write(f"built whole-body MPC: {mpc.problem.n_vars} decision variables in {mpc.build_time:.2f} s\n")

        recorder = VideoRecorder(sim.client, video, fps=VIDEO_FPS, size=VIDEO_SIZE,
                                 follow=lambda: sim.observe().q[list(robot.base_joints[:2])].tolist() + [0.6]) \
            if video else None
        every = frame_every(scenario.sim.control_dt, VIDEO_FPS)

        def record(row: dict) -> None:
            rows.append(row)
            if not row["success"]:
                log.write(f"t={row['t']:.2f}s: solve failed ({row['status']}); held the last good plan\n")
                log.flush()
            if row.get("planner_success") is False:
                log.write(f"t={row['t']:.2f}s: planner failed ({row['planner_status']}); held its last plan\n")
            if recorder and row["step"] % every == 0:
                recorder.capture()

        with Progress(TextColumn(f"[bold]{scenario.name}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), disable=not progress, transient=False) as bar:
            task = bar.add_task("run", total=int(round(scenario.sim.duration / scenario.sim.control_dt)))
            start = time.perf_counter()
            run_loop(mpc, sim, references, scenario.sim.duration, scenario.sim.control_dt, scenario.sim.substeps,
                     record, lambda done, total: bar.update(task, completed=done), watch,
                     obstacle_predictor(scenario.world.obstacles))
        summary["wall_time_s"] = time.perf_counter() - start
        sim.close()
        summary["status"] = "completed"
    except BaseException as exc:  # noqa: BLE001 - record why (interrupts too), then report
        reason = f"{type(exc).__name__}: {str(exc).strip().splitlines()[-1] if str(exc).strip() else ''}"
        summary |= {"status": "failed", "error": reason}
        log.write(traceback.format_exc())
        if not isinstance(exc, Exception):
            raise
        raise RunFailed(out, reason) from exc
    finally:
        if recorder:  # a run that fails part-way keeps its video up to there
            summary["video"] = str(recorder.close())
        steps = pd.DataFrame(rows)
        if len(steps) and twin is not None:
            steps = displacement_from_twin(steps, twin, list(scenario.robot.end_effectors))
        steps.to_csv(out / "steps.csv", index=False)
        if len(steps):
            hands = list(robot.hand_names)
            summary |= summarise(steps, hands)
            if scenario.task is not None:
                summary["task"] = task_outcome(steps, scenario, hands)
            outcome = summary.get("task", summary)  # force and push metrics sit beside the task's
            if (force := force_outcome(steps, hands)) is not None:
                outcome["force"] = force
            if scenario.pushes:
                on_hand = {p.name: pushed_hand(p, robot.urdf, scenario.robot.end_effectors) for p in scenario.pushes}
                outcome["pushes"] = push_outcome(steps, scenario.pushes, hands, on_hand)
        (out / "meta.json").write_text(json.dumps(meta, indent=2))
        (out / "summary.json").write_text(json.dumps(summary, indent=2))
        log.write(f"status: {summary['status']}\n")
        log.close()
        if len(steps):
            from harmony_cli.plots import plot_run
            plot_run(out, steps, list(robot.hand_names))
            if scenario.task is not None:
                from harmony_cli.plots import plot_top_down
                plot_top_down(out, steps, scenario, list(robot.hand_names))
            if scenario.pushes or any(c.endswith("_force_ref_N") for c in steps.columns):
                from harmony_cli.plots import plot_forces, plot_push
                plot_forces(out, steps, list(robot.hand_names), scenario.pushes)
                for push in scenario.pushes:
                    plot_push(out, steps, list(robot.hand_names), push, outcome["pushes"][push.name]["pushed_hand"])
    return out
