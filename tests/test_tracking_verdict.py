"""A hand-trajectory run's verdict: the hands within the reference's tolerance, or a failed run."""

import json

import numpy as np
import pandas as pd
import pytest
from conftest import SMOKE, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.report.tracking import Verdict, tracking_verdict
from harmony_cli.scenario.task import TrackingTolerance

DT = 0.02
TOLERANCE = TrackingTolerance()  # 5 cm, 15 deg, 0.5 s


def _steps(position: np.ndarray, rotation: np.ndarray | None = None) -> pd.DataFrame:
    """Steps whose left hand has these errors [m] (and [deg]) and whose right hand tracks exactly."""
    rotation = np.zeros_like(position) if rotation is None else rotation
    zero = np.zeros_like(position)
    return pd.DataFrame(
        {
            "t": DT * np.arange(len(position)),
            "left_error_m": position,
            "right_error_m": zero,
            "left_rot_error_deg": rotation,
            "right_rot_error_deg": zero,
        }
    )


def _off_for(steps: int, size: float = 0.2, total: int = 200, start: int = 40) -> np.ndarray:
    error = np.full(total, 0.01)
    error[start : start + steps] = size
    return error


@pytest.mark.parametrize(
    "steps, verdict", [(25, Verdict.OK), (26, Verdict.FAILED)], ids=["exactly-the-duration", "one-step-longer"]
)
def test_the_hands_may_leave_the_tolerance_for_its_duration_and_no_longer(steps, verdict):
    tracking = tracking_verdict(_steps(_off_for(steps)), ["left", "right"], TOLERANCE, DT)
    assert tracking.verdict is verdict
    assert tracking.longest_outside_s == pytest.approx(steps * DT)
    assert tracking.outside_from_s == pytest.approx(40 * DT)


def test_short_excursions_apart_do_not_add_up_to_a_failure():
    error = np.full(300, 0.01)
    for start in (20, 80, 140, 200):
        error[start : start + 20] = 0.3  # 0.4 s each, 1.6 s in all
    assert tracking_verdict(_steps(error), ["left", "right"], TOLERANCE, DT).verdict is Verdict.OK


def test_a_hand_turned_beyond_the_rotation_tolerance_fails_with_its_position_on_the_reference():
    rotation = _off_for(60, size=40.0)
    tracking = tracking_verdict(_steps(np.zeros(200), rotation), ["left", "right"], TOLERANCE, DT)
    assert tracking.verdict is Verdict.FAILED and tracking.longest_outside_s == pytest.approx(60 * DT)


def test_a_reference_the_robot_cannot_follow_completes_with_tracking_failed_and_exit_code_1(tmp_path):
    out = tmp_path / "run"
    # 1.5 m in 1 s, up to 2.8 m/s: the hands fall tens of centimetres behind, for most of a second
    runaway = ["reference.length=1.5", "reference.duration=1.0", "sim.duration=1.5"]
    sets = [arg for o in runaway for arg in ("--set", o)]
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", *sets])
    assert result.exit_code == 1, result.output
    assert "tracking failed: the hands were off the reference" in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["tracking"]["verdict"] == "failed"
    assert summary["tracking"]["longest_outside_s"] > TOLERANCE.duration


@needs_pybullet
def test_arms_whose_motors_give_way_complete_with_tracking_failed(tmp_path):
    # PyBullet's motors let twin_arm's arms give 7-17 mrad under gravity from the first step, commanded to stay at
    # home; the whole-body MPC starts every solve from the measured joints and follows them, and the hands turn 16 deg
    # off the catalogue S (no solve fails), which the verdict reads. MuJoCo's servos hold the same arms: 1.3 deg
    out = tmp_path / "run"
    scene = str(SMOKE.parents[1] / "robots" / "s_shape.yaml")
    sets = ["--set", "robot.preset=twin_arm", "--set", "sim.engine=pybullet"]
    result = CliRunner().invoke(app, ["run", scene, *sets, "--out", str(out), "--quiet"])
    assert result.exit_code == 1, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["failed_solves"] == 0
    assert summary["tracking"]["verdict"] == "failed"
    assert summary["tracking_error"]["max_m"] < TOLERANCE.position  # within the position tolerance throughout:
    assert summary["tracking_error"]["max_rot_deg"] > TOLERANCE.rotation_deg  # it is the hands' rotation that fails


def _scara_urdf(wrist_room: float) -> str:
    """Two planar arms (shoulder, elbow, wrist: all yaw joints, 0.4 m links, a 0.1 m tool) on a torso; at home
    (shoulder 1, elbow -2, wrist 1 rad, mirrored on the right) the hands point forward and reaching 0.3 m further
    forward turns each wrist towards 0, through a limit `wrist_room` rad from home on that side."""
    inertial = (
        '<inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
    )

    def joint(name, parent, child, xyz, lower=-2.5, upper=2.5, kind="revolute"):
        moving = f'<axis xyz="0 0 1"/><limit lower="{lower}" upper="{upper}" effort="50" velocity="2"/>'
        return (
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="0 0 0"/>{moving if kind == "revolute" else ""}</joint>'
        )

    parts = [f'<robot name="scara"><link name="torso">{inertial}</link>']
    for side, y, sign in (("l", 0.2, 1), ("r", -0.2, -1)):
        parts += [f'<link name="{side}_{link}">{inertial}</link>' for link in ("upper", "fore", "hand")]
        limits = (1 - wrist_room, 2.5) if sign > 0 else (-2.5, wrist_room - 1)
        parts += [
            joint(f"{side}_shoulder", "torso", f"{side}_upper", f"0 {y} 0.9"),
            joint(f"{side}_elbow", f"{side}_upper", f"{side}_fore", "0.4 0 0"),
            joint(f"{side}_wrist", f"{side}_fore", f"{side}_hand", "0.4 0 0", *limits),
            f'<link name="{side}_tool"/>',
            joint(f"{side}_tool_joint", f"{side}_hand", f"{side}_tool", "0.1 0 0", kind="fixed"),
        ]
    return "\n".join([*parts, "</robot>"])


@pytest.mark.parametrize("wrist_room, exit_code", [(2.0, 0), (0.1, 1)], ids=["limit-far", "limit-0.1-rad-away"])
def test_a_wrist_near_the_limit_the_s_needs_to_pass_rests_on_it_and_fails_the_run(tmp_path, wrist_room, exit_code):
    # with the base pinned the arms are not redundant for the hands' planar poses: where the S needs a wrist past its
    # limit, the whole-body MPC's optimum (no solve fails) holds the wrist on its bound and gives up the hands'
    # position for their heading; the same robot with room tracks the S within the tolerance
    (tmp_path / "scara.urdf").write_text(_scara_urdf(wrist_room))
    one = float(np.degrees(1.0))
    home = ", ".join(
        f"{side}_{joint}: {value}"
        for side, sign in (("l", 1), ("r", -1))
        for joint, value in (("shoulder", sign * one), ("elbow", -2 * sign * one), ("wrist", sign * one))
    )
    scene = tmp_path / "scara.yaml"
    scene.write_text(
        "schema: 2\nname: scara\nrobot:\n  urdf: scara.urdf\n  end_effectors: {left: l_tool, right: r_tool}\n"
        f"  mount: null\n  pinned_joints: [base_x, base_y, base_yaw]\n  home: {{{home}}}\n"
        "reference: {type: s_curve, duration: 8.0, length: 0.3, lateral: 0.05, start: 0.5}\n"
        "mpc: {transcription: bezier, horizon: 2.0, knots: 6, control_points: 6}\nsim: {duration: 9.0}\n"
    )
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(scene), "--out", str(out), "--quiet"])
    assert result.exit_code == exit_code, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed_solves"] == 0
    wrist = pd.read_csv(out / "steps.csv")["q_l_wrist"].iloc[-1]
    if exit_code:
        assert summary["tracking"]["verdict"] == "failed"
        assert wrist == pytest.approx(1 - wrist_room, abs=1e-3)  # resting on its limit
    else:
        assert summary["tracking"]["verdict"] == "ok" and wrist < 0.9  # it passed where the other limit stands
