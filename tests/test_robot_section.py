"""The robot section beyond the URDF: presets, tool frames, mounting, the base's start, home units, and what
`validate` rejects about a robot (one line, the three closest names)."""

from __future__ import annotations

from pathlib import Path

import casadi
import numpy as np
import pytest
from conftest import assert_rejected, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.robot.presets import available_presets
from harmony_cli.scenario import load_scenario, robot_of

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    from harmony_cli.sim.bullet import BulletSimulation
except ImportError:
    pass

runner = CliRunner()
TWIN = "name: x\nrobot: {preset: twin_arm%s}\nreference: {type: hold}\n"


def _robot(tmp_path: Path, fields: str = ""):
    path = tmp_path / "robot.yaml"
    path.write_text(TWIN % fields)
    scenario = load_scenario(path)
    return scenario, robot_of(scenario, tmp_path)


def _position(robot, link: str, q) -> np.ndarray:
    return np.array(casadi.DM(robot.model.get_global_link_position(link, q))).ravel()


def _rotation(robot, link: str, q) -> np.ndarray:
    return np.array(casadi.DM(robot.model.get_global_link_rotation(link, q)))


def test_a_mount_raises_every_hand_frame_by_its_height(tmp_path):
    _, plain = _robot(tmp_path)
    _, mounted = _robot(tmp_path, ", mount: {xyz: [0.1, 0, 0.25], rpy_deg: [0, 0, 90]}")
    assert mounted.n_dof == plain.n_dof
    for link in plain.end_effectors:
        p, m = _position(plain, link, plain.home), _position(mounted, link, mounted.home)
        np.testing.assert_allclose(m, [0.1 - p[1], p[0], p[2] + 0.25], atol=1e-9)  # yawed 90 deg, then lifted


def test_the_base_pose_is_the_start_of_the_base_joints(tmp_path):
    _, robot = _robot(tmp_path, ", base_pose: [1.5, -2.0, 30]")
    np.testing.assert_allclose(robot.home[list(robot.base_joints)], [1.5, -2.0, np.deg2rad(30)])


@needs_pybullet
def test_a_declared_tool_frame_sits_on_its_parent_and_carries_the_wrist_sensor(tmp_path):
    tools = ", tools: {left: {parent: l_hand, xyz: [0.05, 0, 0.02], rpy_deg: [90, 0, 0], pad: [0.05, 0.05, 0.01]}}"
    scenario, robot = _robot(tmp_path, tools)
    assert robot.end_effectors[0] == "harmony_left_tool" and robot.wrist_sensors[0] == "harmony_left_pad_joint"
    q = robot.home
    hand_p, hand_r = _position(robot, "l_hand", q), _rotation(robot, "l_hand", q)
    np.testing.assert_allclose(_position(robot, "harmony_left_tool", q), hand_p + hand_r @ [0.05, 0, 0.02], atol=1e-9)
    np.testing.assert_allclose(_rotation(robot, "harmony_left_tool", q)[:, 2], hand_r @ [0, -1, 0], atol=1e-9)
    sim = BulletSimulation(robot, scenario.sim)  # PyBullet puts the frame where OpTaS does
    try:
        np.testing.assert_allclose(sim.observe().hand_positions[0], _position(robot, "harmony_left_tool", q), atol=1e-6)
    finally:
        sim.close()


HAND_ON_WRIST = ", end_effectors: {left: l_hand, right: r_grasp}"  # l_hand hangs from the wrist's yaw joint


def test_a_hand_link_on_a_movable_joint_gets_the_tool_frame_a_zero_offset_tools_entry_gives(tmp_path, rng):
    _, default = _robot(tmp_path, HAND_ON_WRIST)
    _, written = _robot(tmp_path, HAND_ON_WRIST + ", tools: {left: {parent: l_hand, xyz: [0, 0, 0]}}")
    assert default.urdf == written.urdf  # the same prepared URDF
    assert default.end_effectors == written.end_effectors == ("harmony_left_tool", "r_grasp")
    assert default.wrist_sensors == written.wrist_sensors == ("harmony_left_pad_joint", "r_ft_joint")
    for q in rng.uniform(default.lower.clip(-2), default.upper.clip(max=2), size=(5, default.n_dof)):
        np.testing.assert_allclose(
            _position(default, "harmony_left_tool", q), _position(default, "l_hand", q), atol=1e-9
        )
        np.testing.assert_allclose(
            _rotation(default, "harmony_left_tool", q), _rotation(default, "l_hand", q), atol=1e-9
        )
    assert "urdf: tool frames at the hand link (a movable joint holds it): 1: left" in default.notes


def test_an_explicit_tool_wins_over_the_default_one_at_a_hand_link(tmp_path):
    _, robot = _robot(tmp_path, HAND_ON_WRIST + ", tools: {left: {parent: l_hand, xyz: [0.05, 0, 0]}}")
    q = robot.home
    hand_p, hand_r = _position(robot, "l_hand", q), _rotation(robot, "l_hand", q)
    np.testing.assert_allclose(_position(robot, "harmony_left_tool", q), hand_p + hand_r @ [0.05, 0, 0], atol=1e-9)
    assert not any("tool frames at the hand link" in note for note in robot.notes)


def test_a_hand_link_whose_joint_is_locked_keeps_that_joint_as_its_wrist_sensor(tmp_path):
    _, robot = _robot(tmp_path, HAND_ON_WRIST + ", active_joints: ['l_shoulder_*', l_elbow, l_wrist_pitch, 'r_*']")
    assert robot.end_effectors == ("l_hand", "r_grasp") and robot.wrist_sensors == ("l_wrist_yaw", "r_ft_joint")


def test_revolute_home_is_in_degrees(tmp_path):
    scenario, robot = _robot(tmp_path, ", home: {l_elbow: 45}")
    assert robot.home[robot.joint_names.index("l_elbow")] == pytest.approx(np.pi / 4)
    assert scenario.robot.home == {"l_elbow": 45.0}


@pytest.mark.parametrize(
    ("fields", "pieces"),
    [
        (", home: {l_elbow: 400}", ["robot.home.l_elbow: 400 deg is outside the joint's limits"]),
        (
            ", end_effectors: {left: l_grsp, right: r_grasp}",
            ["robot.end_effectors.left: 'l_grsp'", "closest", "l_grasp"],
        ),
        (", active_joints: [l_sholder_pitch]", ["robot.active_joints: 'l_sholder_pitch'", "l_shoulder_pitch"]),
        (
            ", pinned_joints: [l_elbow], active_joints: ['r_*']",
            ["robot.pinned_joints: 'l_elbow' is not an active joint"],
        ),
        (", home: {base_yaw: 10}", ["robot.home.base_yaw: a base joint", "robot.base_pose"]),
        (", tools: {left: {parent: l_hnd, xyz: [0, 0, 0]}}", ["robot.tools.left.parent: 'l_hnd'", "l_hand"]),
        (", mount: atuo", ["robot.mount: 'atuo': not a mount", "auto"]),
    ],
)
def test_what_a_run_would_reject_about_the_robot_validate_rejects_in_one_line(tmp_path, fields, pieces):
    path = tmp_path / "bad.yaml"
    path.write_text(TWIN % fields)
    assert_rejected(path, pieces)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output


def test_a_mount_on_a_urdf_with_its_own_base_is_refused(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nrobot: {preset: eva, mount: {xyz: [0, 0, 1]}}\nreference: {type: hold}\n")
    assert_rejected(path, ["robot.mount", "has its own base joints"])


def test_a_misspelt_name_gets_the_closest_names_not_the_whole_list():
    from harmony_cli.names import closest

    names = [f"LINK_{i}" for i in range(50)] + ["LARM_TOOL", "RARM_TOOL", "LARM_TOOL_JOINT", "LARM_FT"]
    suggestion = closest("LARM_TOOLS", names)
    assert suggestion.startswith("closest (of 54): LARM_TOOL, ") and suggestion.count(",") == 2
    assert "LINK_" not in suggestion


@pytest.mark.parametrize(
    ("preset", "ahead", "height", "active"),
    [("pr2", 0.6, 0.9, 18), ("tiago_dual", 0.45, 0.9, 18), ("baxter", 0.7, 1.05, 17)],
)
def test_a_catalogue_preset_holds_its_pads_facing_where_its_file_says(tmp_path, preset, ahead, height, active):
    """Built from the package's unedited URDF: the active joints the preset names, and at home both pads 0.34 m
    apart, `ahead` in front of the base at `height`, their normals facing each other (the preset file's comment)."""
    _, robot = _robot_of_preset(tmp_path, preset)
    assert robot.n_dof == active
    (left, left_r), (right, right_r) = ((p.ravel(), r) for p, r in robot.hand_poses_numeric(robot.home))
    np.testing.assert_allclose([left[0], right[0], left[2], right[2]], [ahead, ahead, height, height], atol=0.01)
    assert left[1] - right[1] == pytest.approx(0.34, abs=0.01)
    np.testing.assert_allclose(left_r[:, 2], [0, -1, 0], atol=0.02)
    np.testing.assert_allclose(right_r[:, 2], [0, 1, 0], atol=0.02)


def _robot_of_preset(tmp_path: Path, preset: str):
    path = tmp_path / f"{preset}.yaml"
    path.write_text(f"name: x\nrobot: {{preset: {preset}}}\nreference: {{type: hold}}\n")
    scenario = load_scenario(path)
    return scenario, robot_of(scenario, tmp_path)


def test_a_scenario_without_a_robot_section_is_eva_from_any_folder(tmp_path):
    path = tmp_path / "elsewhere" / "hold.yaml"
    path.parent.mkdir()
    path.write_text("name: x\nreference: {type: hold}\n")
    scenario = load_scenario(path)
    assert robot_of(scenario, path.parent).n_dof == 18


def test_robots_lists_presets_and_show_prints_joints_frames_and_gravity():
    listed = runner.invoke(app, ["robots"])
    assert listed.exit_code == 0 and all(name in listed.output for name in available_presets())
    shown = runner.invoke(app, ["robots", "show", "twin_arm"])
    assert shown.exit_code == 0, shown.output
    assert "l_shoulder_pitch" in shown.output and "hand left: frame l_grasp" in shown.output
    assert "gravity check (Pinocchio)" in shown.output
    wrong = runner.invoke(app, ["robots", "show", "pr3"])
    assert wrong.exit_code == 2 and "closest" in wrong.output


@needs_pybullet
def test_a_catalogue_robot_run_prints_only_its_summary_and_logs_the_rest(tmp_path):
    """TIAGo dual (86 joints locked, 112 links merged, 219 foreign elements): the console gets the summary line
    alone (--quiet: no progress bar); the parsers' and PyBullet's messages land in run.log."""
    import subprocess
    import sys

    path = tmp_path / "tiago.yaml"
    path.write_text("name: tiago\nrobot: {preset: tiago_dual}\nreference: {type: hold}\nsim: {duration: 0.1}\n")
    harmony = Path(sys.executable).with_name("harmony")
    out = tmp_path / "run"
    done = subprocess.run(
        [str(harmony), "run", str(path), "--out", str(out), "--quiet"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == "" and done.stdout.splitlines() == [done.stdout.strip()], done.stdout
    assert done.stdout.startswith(f"{out}: completed, 108 decision variables")
    log = (out / "run.log").read_text()
    assert "urdf: locked joints (off the chains to the hands): 86" in log and "pybullet: " in log


def test_a_scenario_names_a_urdf_and_its_meshes_inside_example_robot_data_as_a_preset_does(tmp_path):
    # the same file a preset names, written the preset's way in a user's robot section: no machine's path in it
    preset = load_scenario(_written(tmp_path, "robot: {preset: tiago_dual}")).robot
    section = (
        "robot: {urdf: 'example-robot-data:example-robot-data/robots/tiago_description/robots/tiago_dual.urdf', "
        "package_paths: ['example-robot-data:'], end_effectors: {left: arm_left_tool_link, right: arm_right_tool_link}}"
    )
    own = load_scenario(_written(tmp_path, section)).robot
    assert own.urdf == preset.urdf and Path(own.urdf).is_file()
    assert own.package_paths == preset.package_paths and Path(own.package_paths[0]).is_dir()


def _written(tmp_path: Path, robot: str) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(f"name: x\n{robot}\nreference: {{type: hold}}\n")
    return path


def test_robots_check_prints_what_harmony_makes_of_a_scenario_s_robot_and_its_reach():
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "smoke" / "twin_arm_turn.yaml"
    result = runner.invoke(app, ["robots", "--check", str(scene)])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].startswith("twin_arm_turn.yaml: ") and "active joints" in lines[0]
    assert any(line.strip().startswith("hand left: frame ") for line in lines)
    reach = [line for line in lines if line.strip().startswith("reach: both hands together")]
    assert len(reach) == 1 and float(reach[0].split("z = ")[1].split()[0]) > 0.5


def test_robots_check_of_a_file_that_is_not_there_is_one_line():
    result = runner.invoke(app, ["robots", "--check", "no/such/scene.yaml"])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output
