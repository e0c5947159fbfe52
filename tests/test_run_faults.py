"""Faults during a run, injected into in-process runs of the smoke S (1 s, 50 control steps): a failed solve holds
the last good plan; anything the run cannot go on from ends it with status failed, a `failure` category and a
reason in summary.json and run.log, the steps so far kept, and one console line (exit 1)."""

from __future__ import annotations

import errno
import itertools
import json
import os
import re
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, SMOKE, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.experiment import pipeline
from harmony_cli.experiment.faults import MAX_HELD_S, RunFault
from harmony_cli.experiment.health import TRACKING_LIMIT_M, Health
from harmony_cli.experiment.run import run_scenario
from harmony_cli.experiment.stream import StepStream, read_stream
from harmony_cli.mpc import wholebody
from harmony_cli.planning import hand_mpc
from harmony_cli.planning.hand_sqp import HandSQP
from harmony_cli.robot.presets import resolve_path
from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    from harmony_cli.sim.bullet import BulletSimulation
except ImportError:
    pass

TWIN = ROOT / "scenarios" / "smoke" / "twin_arm_turn.yaml"
DT = 0.02  # the smoke S's control period [s]


def _run(out: Path, *overrides: str, scenario: Path = SMOKE) -> tuple[int, list[str], dict, pd.DataFrame]:
    """`harmony run` in process: exit code, console lines, summary.json, steps.csv."""
    sets = [a for o in overrides for a in ("--set", o)]
    result = CliRunner().invoke(app, ["run", str(scenario), "--out", str(out), "--quiet", *sets])
    assert "Traceback" not in result.output and not isinstance(result.exception, OSError | RuntimeError)
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else {}
    csv = out / "steps.csv"
    steps = pd.read_csv(csv) if csv.is_file() and csv.stat().st_size > 1 else pd.DataFrame()
    return result.exit_code, result.output.strip().splitlines(), summary, steps


def _faulty_solver(monkeypatch, first: int, last: float, kind: str) -> None:
    """The whole-body MPC's solver raises ("raise") or reports success with a NaN solution ("nan") or one whose
    command overflows ("huge": finite control points of alternating sign at the largest float) at solves
    first..last."""
    real = wholebody.make_solver

    def make(problem, spec):
        solver, count = real(problem, spec), itertools.count()

        def solve(x0, lbx, ubx, p):
            faulty = first <= next(count) <= last
            if faulty and kind == "raise":
                raise RuntimeError("injected fault")
            result = solver.solve(x0, lbx, ubx, p)
            if not faulty:
                return result
            huge = np.where(np.arange(result.x.size) % 2, 1.7e308, -1.7e308)
            return replace(result, x=huge if kind == "huge" else np.full_like(result.x, np.nan))

        return SimpleNamespace(path=solver.path, solve=solve, prepare=solver.prepare)

    monkeypatch.setattr(wholebody, "make_solver", make)


def _after_control_step(monkeypatch, step: int, act) -> None:
    """`act(sim)` once the physics of control step `step` has run (the next observation sees it)."""
    real = BulletSimulation.step

    def stepped(self: BulletSimulation, substeps: int) -> None:
        real(self, substeps)
        if self.physics_steps == (step + 1) * substeps:
            act(self)

    monkeypatch.setattr(BulletSimulation, "step", stepped)


def _teleport(joint: str, by: float):
    """An `act` that moves a joint by `by` from where it is, at once (PyBullet's resetJointState)."""

    def act(sim: BulletSimulation) -> None:
        j = sim.joints[sim.robot.index(joint)]
        sim.client.resetJointState(sim.body, j, sim.client.getJointState(sim.body, j)[0] + by)

    return act


def test_a_solver_exception_holds_the_last_good_plan_and_the_run_recovers(monkeypatch, tmp_path):
    _faulty_solver(monkeypatch, 10, 14, "raise")
    out = run_scenario(SMOKE, out=tmp_path / "run", progress=False)
    summary, steps = json.loads((out / "summary.json").read_text()), pd.read_csv(out / "steps.csv")
    assert summary["status"] == "completed" and len(steps) == 50 and summary["failed_solves"] == 5
    failed = steps[~steps["success"]]
    assert list(failed["step"]) == [10, 11, 12, 13, 14] and failed["held_last_plan"].all()
    assert (failed["status"] == "exception RuntimeError: injected fault").all()
    assert (
        "t=0.20s: solve failed (exception RuntimeError: injected fault); held the last good plan"
        in (out / "run.log").read_text()
    )
    assert summary["tracking_error"]["max_m"] < 0.02  # the held plan carried it over the gap


def test_a_solver_that_keeps_raising_fails_the_run_after_a_second_of_held_plans(monkeypatch, tmp_path):
    _faulty_solver(monkeypatch, 10, np.inf, "raise")
    code, lines, summary, steps = _run(tmp_path / "run", "sim.duration=2.0")
    assert code == 1 and len(lines) == 1 and "run failed" in lines[0] and "whole-body MPC failed" in lines[0]
    assert (summary["status"], summary["failure"]) == ("failed", "solver")
    held_s = steps["t"].iloc[-1] - 0.2  # every solve failed from t = 0.2 s on
    assert MAX_HELD_S < held_s <= MAX_HELD_S + 2 * DT and len(steps) < 100
    assert f"held for at most {MAX_HELD_S:g} s" in summary["reason"]


def test_a_first_solve_that_fails_leaves_no_plan_to_hold_and_fails_the_run_as_a_solver_fault(monkeypatch, tmp_path):
    _faulty_solver(monkeypatch, 0, np.inf, "raise")
    code, lines, summary, steps = _run(tmp_path / "run")
    assert code == 1 and len(lines) == 1 and "first whole-body MPC solve failed" in lines[0], lines
    assert (summary["status"], summary["failure"]) == ("failed", "solver")  # was "error": a bare RuntimeError
    assert "no plan to hold; stopped before its first step" in summary["reason"] and len(steps) == 0


@needs_pybullet
@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy's on the overflow injected ("huge")
@pytest.mark.parametrize("kind, status", [("nan", "non-finite solution"), ("huge", "non-finite command")])
def test_a_nan_solution_or_command_never_reaches_the_simulator_and_the_last_plan_is_held(
    kind, status, monkeypatch, tmp_path
):
    _faulty_solver(monkeypatch, 10, 14, kind)
    sent = []
    real = BulletSimulation.apply
    monkeypatch.setattr(BulletSimulation, "apply", lambda self, q, qd: (sent.append(np.r_[q, qd]), real(self, q, qd)))
    out = run_scenario(SMOKE, out=tmp_path / "run", progress=False)
    steps = pd.read_csv(out / "steps.csv")
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"
    assert len(sent) == 50 and np.isfinite(sent).all()
    assert list(steps.loc[steps["status"] == status, "step"]) == [10, 11, 12, 13, 14]
    assert steps.loc[10:14, "held_last_plan"].all()


def test_a_planner_exception_or_nan_plan_holds_its_last_plan(monkeypatch, tmp_path):
    real, real_sqp, count = hand_mpc.HandMPC.step, HandSQP._sqp_step, itertools.count()
    nan_now = [False]

    def nan_sqp(self, *args):  # the QP's step: NaN while nan_now
        step, *rest = real_sqp(self, *args)
        return (np.full_like(step, np.nan) if nan_now[0] and step is not None else step), *rest

    def planned(self, *args, **kwargs):
        n = next(count)
        if n in (10, 11):
            raise np.linalg.LinAlgError("injected fault")
        nan_now[0] = n in (12, 13)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(HandSQP, "_sqp_step", nan_sqp)
    monkeypatch.setattr(hand_mpc.HandMPC, "step", planned)
    out = run_scenario(TWIN, ["sim.duration=0.6"], out=tmp_path / "run", progress=False)
    steps = pd.read_csv(out / "steps.csv")
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"
    status = steps.set_index("step")["planner_status"]
    assert list(status[10:12]) == ["exception LinAlgError: injected fault"] * 2
    assert list(status[12:14]) == ["non-finite plan"] * 2 and steps["planner_success"].iloc[14:].all()
    assert np.isfinite(steps.filter(like="_ref_").to_numpy()).all()  # the held plan's references
    assert (
        "t=0.20s: planner failed (exception LinAlgError: injected fault); held its last plan"
        in (out / "run.log").read_text()
    )


@needs_pybullet
def test_a_lost_simulator_connection_fails_the_run_and_keeps_the_steps_so_far(monkeypatch, tmp_path):
    _after_control_step(monkeypatch, 19, lambda sim: sim.client.disconnect())
    code, lines, summary, steps = _run(tmp_path / "run")
    assert code == 1 and len(lines) == 1 and "simulator connection lost" in lines[0]
    assert (summary["status"], summary["failure"], summary["steps"], len(steps)) == ("failed", "simulator", 20, 20)
    assert "after 20 steps (t = 0.38 s simulated)" in summary["reason"]
    log = (tmp_path / "run" / "run.log").read_text()
    assert "run failed (simulator): simulator connection lost" in log and log.endswith("status: failed\n")


def test_a_full_disk_mid_run_fails_the_run_naming_the_disk_and_keeps_what_was_written(monkeypatch, tmp_path):
    class FillsUp(StepStream):  # writes every row at once; the disk is full after 20
        def __init__(self, path: Path):
            super().__init__(path, every_s=0.0)

        def flush(self) -> None:
            if self._pending and self._pending[-1]["step"] >= 20:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            super().flush()

    monkeypatch.setattr(pipeline, "StepStream", FillsUp)
    out = tmp_path / "run"
    code, lines, summary, steps = _run(out)
    assert code == 1 and len(lines) == 1 and "disk full: no space left on the device of /" in lines[0]
    assert (summary["status"], summary["failure"]) == ("failed", "disk") and "t = 0.40 s" in summary["reason"]
    assert len(read_stream(out / "steps.jsonl")) == 20 and len(steps) == 21  # the row it could not stream too
    assert "run failed (disk): disk full" in (out / "run.log").read_text()


def test_a_full_disk_while_the_summary_is_written_leaves_no_half_summary(monkeypatch, tmp_path):
    real = Path.write_text

    def write_text(self: Path, text: str, *args, **kwargs) -> int:
        if self.name == "summary.json.part":
            real(self, text[: len(text) // 2])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, text, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    out = tmp_path / "run"
    code, lines, summary, steps = _run(out)
    assert code == 1 and len(lines) == 1 and "disk full" in lines[0] and "writing summary.json" in lines[0]
    assert not (out / "summary.json").exists() and not (out / "summary.json.part").exists()
    assert len(steps) == 50 and (out / "run.log").read_text().endswith("status: failed\n")


@needs_pybullet
def test_a_joint_teleported_past_its_limits_fails_the_run_as_diverged_naming_the_joint(monkeypatch, tmp_path):
    _after_control_step(monkeypatch, 20, _teleport("LARM_JOINT1", 2.5))
    code, lines, summary, steps = _run(tmp_path / "run")
    assert code == 1 and len(lines) == 1 and "joint LARM_JOINT1" in lines[0]
    assert (summary["status"], summary["failure"]) == ("failed", "diverged")
    assert "at t = 0.42 s, outside its URDF limits" in summary["reason"] and len(steps) == 22  # the step that shows it


@needs_pybullet
def test_a_base_jump_fails_the_run_as_diverged(monkeypatch, tmp_path):
    _after_control_step(monkeypatch, 20, _teleport("base_x", 1.0))
    code, lines, summary, steps = _run(tmp_path / "run")
    assert code == 1 and len(lines) == 1 and "the base moved 1.0" in lines[0]
    assert (summary["failure"], len(steps)) == ("diverged", 22) and "to t = 0.42 s" in summary["reason"]


@pytest.mark.parametrize("engine", [pytest.param("pybullet", marks=needs_pybullet), "mujoco"])
def test_a_robot_starting_inside_an_obstacle_is_refused_before_the_loop(tmp_path, engine):
    block = "world.obstacles=[{name: block, shape: box, position: [0.0, 0.0, 0.3], size: [0.4, 0.4, 0.4]}]"
    code, lines, summary, steps = _run(tmp_path / "run", block, f"sim.engine={engine}")
    assert code == 1 and len(lines) == 1 and "inside obstacle block" in lines[0] and "at the start" in lines[0]
    assert (summary["status"], summary["failure"], len(steps)) == ("failed", "penetration", 0)
    assert "decision_variables" not in summary  # refused before the MPCs were built


def _g1(tmp_path: Path, mount: str | None) -> Path:
    """The smoke S on Unitree's G1 humanoid as example-robot-data ships it (floating base, legs), its pelvis on the
    virtual base as `robot.mount` (YAML) says (None: not given, as a new user's first try leaves it)."""
    share = resolve_path("example-robot-data:", "g1")
    urdf = f"{share}/example-robot-data/robots/g1_description/urdf/g1_29dof_rev_1_0.urdf"
    pad = "xyz: [0, 0, 0], rpy_deg: [0, 0, 0], pad: [0.05, 0.05, 0.01]"
    mount = "" if mount is None else f"  mount: {mount}\n"
    robot = (
        f"robot:\n  urdf: {urdf}\n  package_paths: [{share}]\n{mount}  tools:\n"
        f"    left: {{parent: left_rubber_hand, {pad}}}\n    right: {{parent: right_rubber_hand, {pad}}}\n"
    )
    scenario = tmp_path / "g1.yaml"
    scenario.write_text(SMOKE.read_text() + robot)
    return scenario


def test_a_package_humanoid_with_its_feet_in_the_ground_is_refused_in_mujoco_too_though_the_robot_skips_the_ground(
    tmp_path,
):
    # MuJoCo's robot does not collide with the ground (it stands on its virtual base joints): the start check
    # measures the robot's geoms against the ground plane instead
    code, lines, summary, _ = _run(tmp_path / "ground", "sim.engine=mujoco", scenario=_g1(tmp_path, "null"))
    assert code == 1 and len(lines) == 1 and "inside the ground" in lines[0], lines
    assert summary["failure"] == "penetration"


def test_a_package_humanoid_placed_with_its_feet_in_the_ground_is_refused_and_runs_once_mounted_clear(tmp_path):
    code, lines, summary, steps = _run(tmp_path / "ground", scenario=_g1(tmp_path, "null"))  # where its URDF puts it
    assert code == 1 and len(lines) == 1, lines  # before: thrown ~1 m by the ground and reported "completed"
    # the deepest link, one of the two feet level with each other (PyBullet names the right, MuJoCo the left)
    assert re.search(r"link (left|right)_ankle_roll_link is 79\.2 cm inside the ground", lines[0]), lines
    assert (summary["failure"], len(steps)) == ("penetration", 0)
    mounted = _g1(tmp_path, "{xyz: [0, 0, 0.80], rpy_deg: [0, 0, 0]}")  # its pelvis at its height
    code, lines, summary, steps = _run(tmp_path / "mounted", scenario=mounted)
    assert code == 0 and summary["status"] == "completed" and len(steps) == 50, lines
    assert summary["tracking_error"]["max_m"] < 0.02


def test_a_package_humanoid_stands_on_its_feet_without_a_mount(tmp_path):
    code, lines, summary, steps = _run(tmp_path / "auto", scenario=_g1(tmp_path, None))
    assert code == 0 and summary["status"] == "completed" and len(steps) == 50, lines
    assert "the root raised 0.79" in (tmp_path / "auto" / "run.log").read_text()


def test_a_hand_far_from_its_reference_is_divergence():
    robot = robot_of(load_scenario(SMOKE), SMOKE.parent)
    health, hands = Health(robot, DT), np.zeros((2, 3))
    health.check(0.0, robot.home, hands, hands + 0.5 * TRACKING_LIMIT_M)
    with pytest.raises(RunFault, match=r"the right hand is 2\.50 m from its reference at t = 0\.02 s"):
        health.check(0.02, robot.home, hands, hands + [[0, 0, 0], [0, 0, 2.5]])


def test_a_normal_run_is_unaffected(tmp_path):
    code, lines, summary, steps = _run(tmp_path / "run")
    assert code == 0 and summary["status"] == "completed" and "failure" not in summary and len(steps) == 50
    assert summary["failed_solves"] == 0 and "failed" not in (tmp_path / "run" / "run.log").read_text()
