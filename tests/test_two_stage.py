"""The two MPCs in series, closed loop in PyBullet (the box lift in MuJoCo too): a robot other than EVA, a box
held by friction, the video, and the experiments report."""

import json
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, assert_exit_follows_outcome, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.scenario.models import installed_engines

runner = CliRunner()
TWIN = ROOT / "scenarios" / "smoke" / "twin_arm_turn.yaml"
BOX = ROOT / "scenarios" / "smoke" / "box_lift.yaml"
PAPER = ROOT / "scenarios" / "paper"
ENGINES = installed_engines()  # MuJoCo alone where PyBullet has no wheels (Python > 3.11)


@pytest.fixture(scope="module")
def twin_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("twin") / "run"
    result = runner.invoke(app, ["run", str(TWIN), "--out", str(out), "--quiet"])
    assert_exit_follows_outcome(result, out)
    return out


def test_a_robot_other_than_eva_runs_the_two_stage_loop_and_turns_to_its_goal(twin_run):
    summary = json.loads((twin_run / "summary.json").read_text())
    task = summary["task"]
    assert summary["status"] == "completed" and summary["n_dof"] == 13  # 10 arm joints + the added base
    assert task["success"] and task["planner_failures"] == 0 and summary["failed_solves"] == 0
    assert all(p["completed_s"] is not None for p in task["phases"])
    assert task["base_yaw_range_deg"] > 60  # the hands' goal faces +y: the base turns
    steps = pd.read_csv(twin_run / "steps.csv")
    assert {"loop_ms", "planner_ms", "planner_status", "phase", "left_goal_error_m"} <= set(steps.columns)
    assert (twin_run / "top_down.png").exists()


@pytest.fixture(scope="module")
def lift_runs(tmp_path_factory) -> dict[str, Path]:
    """box_lift run closed loop in each engine."""
    runs = {}
    for engine in ENGINES:
        out = tmp_path_factory.mktemp(f"lift_{engine}") / "run"
        result = runner.invoke(app, ["run", str(BOX), "--out", str(out), "--quiet", "--set", f"sim.engine={engine}"])
        assert_exit_follows_outcome(result, out)
        runs[engine] = out
    return runs


@pytest.fixture(params=ENGINES)
def lift_run(request, lift_runs) -> Path:
    return lift_runs[request.param]


@needs_pybullet
def test_the_two_engines_lift_the_box_to_the_same_place_within_a_centimetre(lift_runs):
    # PyBullet's friction is rigid, MuJoCo's soft: the box slides some millimetres down the pads in MuJoCo while the
    # lift accelerates; the controller, the grasp and the lift are the same
    ends = {
        engine: pd.read_csv(out / "steps.csv")[["box_x", "box_y", "box_z"]].iloc[-1]
        for engine, out in lift_runs.items()
    }
    assert np.linalg.norm(ends["pybullet"] - ends["mujoco"]) < 0.01, ends


def test_a_lift_a_box_task_without_a_goal_succeeds_when_every_phase_reached_its_goal_with_the_box_held(lift_run):
    task = json.loads((lift_run / "summary.json").read_text())["task"]
    assert task["box_goal_error_m"] is None and all(p["completed_s"] is not None for p in task["phases"])
    assert task["success"] and task["failure"] is None, task


def test_the_box_is_lifted_by_friction_alone_and_never_dropped(lift_run):
    steps = pd.read_csv(lift_run / "steps.csv")
    assert not steps["dropped"].any()
    held = steps[steps["holding"]]
    assert held["box_touches_robot"].all()
    assert steps["box_z"].iloc[-1] - steps["box_z"].iloc[0] > 0.08  # lifted (the goal: 12 cm)
    assert held["box_tilt_deg"].max() < 20
    # the squeeze is the admittance's 20 N force loop, measured by the wrist sensors once the ramp is over. While
    # the grasp closes on the written faces it is a proportional loop against the plan's grip width (K dp balances
    # the force error) and settles short of its reference; once the box is held the plan keeps the width the
    # pads stand at, and the loop settles on its reference (how far short in the grasp depends on how stiff the
    # servos and the contacts behind the pads are: 3 N in PyBullet, 4 N in MuJoCo)
    settled = steps[steps["left_force_ref_N"] >= 20.0]
    for phase, low, high in (("squeeze", -0.25 * 20.0, -1.0), ("lift", -1.5, 1.0)):
        at = settled[settled["phase"] == phase].iloc[10:]  # 0.2 s after the ramp for the loop to settle
        for hand in ("left", "right"):
            error = at[f"{hand}_force_normal_N"] - at[f"{hand}_force_ref_N"]
            assert len(at) > 50 and low < error.mean() < high and error.std() < 1.0
            # no chatter at half the control rate (raw force into the admittance: p95 step-to-step change 14 N)
            assert np.percentile(np.abs(np.diff(at[f"{hand}_force_normal_N"])), 95) < 1.0


def test_the_pads_friction_carries_at_least_the_lifted_box_weight_as_statics_says(lift_run):
    # the engine's contact forces against statics: held still at the lift's end, the vertical parts of the pads'
    # friction forces sum to the box's weight (mu = 0.8 x 1.0, m = 0.8 kg). Each pad's friction force (friction used
    # x mu x normal force) may also have a horizontal part, which the two pads exchange equal and opposite: statics
    # does not fix it, the contact solver's distribution of the forces does, and it differs between engines and
    # between CPUs' floating point. So the magnitudes together are the weight or more, never less
    steps = pd.read_csv(lift_run / "steps.csv")
    still = steps[steps["t"] >= steps["t"].iloc[-1] - 0.5]
    # (the median over the half second: a step's friction magnitudes per pad come and go as the solver shares them)
    carried = sum(still[f"{h}_friction_used"] * 0.8 * still[f"{h}_contact_N"] for h in ("left", "right"))
    assert np.median(carried) >= 0.98 * 0.8 * 9.81
    for hand in ("left", "right"):
        assert (still[f"{hand}_contact_points"] >= 3).all()  # flat on the face, not on an edge
        assert still[f"{hand}_contact_normal_off_face_deg"].max() < 1.0  # normals along the box's face


def test_video_is_written_headless_with_one_frame_per_tenth_of_a_second(tmp_path):
    video = tmp_path / "run.gif"
    result = runner.invoke(
        app,
        [
            "run",
            str(TWIN),
            "--out",
            str(tmp_path / "run"),
            "--quiet",
            "--set",
            "sim.duration=1.0",
            "--video-file",
            str(video),
        ],
    )
    assert_exit_follows_outcome(result, tmp_path / "run")
    frames = imageio.mimread(video)
    assert len(frames) == 10 and frames[0].shape[:2] == (360, 480)
    assert np.std(frames[-1]) > 0


def test_experiments_report_tabulates_runs_with_their_plots(twin_run, tmp_path):
    result = runner.invoke(app, ["experiments", str(twin_run), "--out", str(tmp_path), "--name", "exp"])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(tmp_path / "exp.csv")
    assert table["experiment"].tolist() == ["twin_arm_turn"] and bool(table["success"].iloc[0])
    assert "twin_arm_turn" in (tmp_path / "exp.md").read_text()
    assert (tmp_path / "twin_arm_turn_top_down.png").exists()


def test_experiments_report_names_a_directory_that_is_not_a_run(tmp_path):
    result = runner.invoke(app, ["experiments", str(tmp_path)])
    assert result.exit_code == 2 and "no summary.json" in result.output


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pick_and_carry", "static_obstacles", "narrow_passage"])
def test_paper_experiment_succeeds_closed_loop(name, tmp_path):
    out = tmp_path / name
    result = runner.invoke(app, ["run", str(PAPER / f"{name}.yaml"), "--out", str(out), "--quiet"])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    task = summary["task"]
    assert task["success"], task
    assert all(v > 0 for c in task["min_clearance_m"].values() for v in c.values())
    if name == "narrow_passage":
        assert task["base_yaw_range_deg"] > 45 and task["planner_failures"] == 0 and summary["failed_solves"] == 0
    if name == "pick_and_carry":  # the carry's 20 N squeeze through the admittance loop
        assert all(hand["rms_N"] <= 3.0 for hand in task["force"]["phases"]["carry"].values())


@pytest.mark.slow
def test_push_recovery_yields_with_admittance_and_the_pusher_presses_harder_without(tmp_path):
    result = runner.invoke(
        app,
        [
            "compare",
            str(PAPER / "push_recovery.yaml"),
            "--grid",
            "admittance.enabled=true,false",
            "--out",
            str(tmp_path),
            "--jobs",
            "2",
        ],
    )
    assert result.exit_code == 0, result.output
    on, off = (
        json.loads((tmp_path / "runs" / f"enabled-{v}" / "summary.json").read_text())["task"] for v in ("true", "false")
    )
    assert on["success"] and not on["box_dropped"] and off["success"]
    push_on, push_off = on["pushes"]["left_hand"], off["pushes"]["left_hand"]
    assert push_on["recovery_s"] is not None and push_off["recovery_s"] is not None
    # the spring pusher builds up less force against the compliant hand, which yields past 1 cm and comes back
    assert push_off["peak_push_N"] > push_on["peak_push_N"]
    # without admittance the hand does not give: the pusher presses with its full force after its quarter-duration
    # ramp, so its impulse is |F| (T - T/8); against the compliant hand it is less
    force, duration = np.linalg.norm(push_off["force_N"]), push_off["duration_s"]
    assert push_off["applied_impulse_N_s"] == pytest.approx(force * (duration - duration / 8), rel=0.05)
    assert push_on["applied_impulse_N_s"] < push_off["applied_impulse_N_s"]
    assert push_on["peak_displacement_m"] > 0.01 > push_off["peak_displacement_m"] and push_on["recovery_s"] > 0


def test_the_wrist_sensors_read_the_held_box_s_weight_within_2_percent(lift_run):
    # held still by friction at the lift's end, the wrists carry the box: the sensors' forces along the vertical sum
    # to its weight, m g (m = 0.8 kg). The grasp frames' x axes point down while the hands are level as at home; the
    # rest of the force across a pad's normal is the grip's internal shear (opposite on the two pads), not weight
    steps = pd.read_csv(lift_run / "steps.csv")
    still = steps[steps["t"] >= steps["t"].iloc[-1] - 0.5]
    assert (still[["left_rot_error_deg", "right_rot_error_deg"]] < 1.0).all(axis=None)  # level: x is vertical
    carried = sum(np.median(still[f"{hand}_force_x_N"]) for hand in ("left", "right"))
    assert np.isclose(carried, 0.8 * 9.81, rtol=0.02), carried
