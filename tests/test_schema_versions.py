"""Scenario schema versions: a file of schema 1 loads with one deprecation line and reads as its upgraded form;
`harmony upgrade` rewrites it in place keeping its comments; an unknown schema and a missing URDF are refused in one
line each."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.scenario import load_scenario
from harmony_cli.scenario.schema import as_current, schema_edits
from harmony_cli.scenario.source import load_yaml_file

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

# EVA as a scenario named it before presets (schema 1): by its URDF's old path, its home in `home_deg`, the motors
# in `sim`; the URDF path is relative to a file in <tmp>/paper/, as it was to scenarios/paper/
OLD = """\
# An EVA scenario as written before presets (schema 1)
name: old_eva   # the run's name
robot:                       # EVA by its URDF
  urdf: ../robots/eva.urdf   # where EVA's URDF lay
  end_effectors: {left: LARM_grasp, right: RARM_grasp}
  pinned_joints: [HEAD_JOINT0, HEAD_JOINT1]     # held at home in every MPC
  home_deg:                  # joint -> home
    LARM_JOINT2: -30
    RARM_JOINT2: -30
    base_x: 10               # the base's start
reference: {type: hold}
sim:
  duration: 1.0
  actuators: ideal           # strong motors
"""
# the same file written by hand at schema 2: base_x was read as 10 degrees, in radians, used as metres
NEW = """\
# An EVA scenario as written before presets (schema 1)
schema: 2
name: old_eva   # the run's name
robot:                       # EVA by its URDF
  preset: eva   # where EVA's URDF lay
  end_effectors: {left: LARM_grasp, right: RARM_grasp}
  pinned_joints: [HEAD_JOINT0, HEAD_JOINT1]     # held at home in every MPC
  home:                  # joint -> home
    LARM_JOINT2: -30
    RARM_JOINT2: -30
    # the base's start
  actuators: ideal
  base_pose: [0.17453292519943295, 0.0, 0.0]
reference: {type: hold}
sim:
  duration: 1.0
  # strong motors
"""


def _write(tmp_path: Path, text: str, name: str = "scenario.yaml") -> Path:
    path = tmp_path / "paper" / name
    path.parent.mkdir(exist_ok=True)
    path.write_text(text)
    return path


def test_a_schema_1_file_validates_with_one_deprecation_line_naming_each_renamed_field(tmp_path):
    path = _write(tmp_path, OLD)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1, result.output
    for piece in (
        "schema 1 is deprecated",
        "robot.urdf '../robots/eva.urdf' (moved) -> robot.preset: eva",
        "robot.home_deg -> robot.home",
        "base_x -> robot.base_pose",
        "sim.actuators -> robot.actuators",
        f"harmony upgrade {path}",
    ):
        assert piece in warnings[0], (piece, warnings[0])


def test_a_schema_1_file_gives_the_same_scenario_as_its_hand_written_schema_2_form(tmp_path):
    old, new = _write(tmp_path, OLD, "old.yaml"), _write(tmp_path, NEW, "new.yaml")
    assert load_scenario(old) == load_scenario(new)
    assert load_scenario(old).robot.base_pose == (math.radians(10), 0.0, 0.0)


def test_upgrade_rewrites_a_schema_1_file_as_the_hand_written_schema_2_file_comments_kept(tmp_path):
    path = _write(tmp_path, OLD)
    result = runner.invoke(app, ["upgrade", str(path)])
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{path}: upgraded to schema 2: robot.urdf"), result.output
    assert path.read_text() == NEW


def test_an_upgraded_file_loads_without_a_notice(tmp_path):
    path = _write(tmp_path, OLD)
    runner.invoke(app, ["upgrade", str(path)])
    notices: list[str] = []
    load_scenario(path, notices=notices)
    assert notices == []


def test_upgrade_leaves_a_file_stating_schema_2_as_it_is(tmp_path):
    path = _write(tmp_path, NEW)
    result = runner.invoke(app, ["upgrade", str(path)])
    assert result.exit_code == 0 and "schema 2 already" in result.output
    assert path.read_text() == NEW


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").rglob("*.yaml")), ids=lambda p: p.name)
def test_a_shipped_scenario_is_current(path):
    assert schema_edits(load_yaml_file(path), path) == ([], [])


def test_a_current_file_without_the_schema_key_loads_without_a_notice(tmp_path):
    path = _write(tmp_path, "name: x\nrobot: {preset: eva, home: {LARM_JOINT2: -30}}\nreference: {type: hold}\n")
    notices: list[str] = []
    load_scenario(path, notices=notices)
    assert notices == []


def test_a_profile_and_an_eva_path_in_flow_style_become_one_preset(tmp_path):
    robot = "{profile: eva, urdf: /old/harmony_cli/robot/profiles/eva.urdf}"
    text = f"name: x  # flow\nrobot: {robot}\nsim: {{actuators: ideal}}\n"
    path = _write(tmp_path, text)
    runner.invoke(app, ["upgrade", str(path)])
    assert path.read_text() == "schema: 2\nname: x  # flow\nrobot: {preset: eva, actuators: ideal}\n"


PRISMATIC = """<robot name="lift">
  <link name="base"/><link name="torso"/><link name="arm"/>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="torso"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.5" effort="100" velocity="0.1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="torso"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
</robot>
"""


def test_a_prismatic_joints_home_deg_becomes_the_metres_schema_1_moved_it(tmp_path):
    (tmp_path / "paper" / "lift.urdf").parent.mkdir()
    (tmp_path / "paper" / "lift.urdf").write_text(PRISMATIC)
    path = _write(tmp_path, "name: x\nrobot: {urdf: lift.urdf, home_deg: {lift: 20, shoulder: 45}}\n")
    notices: list[str] = []
    robot = as_current(load_yaml_file(path), path, notices)["robot"]
    assert robot["home"] == {"lift": math.radians(20), "shoulder": 45}
    assert "lift: 20 -> 0.349066" in notices[0]


@pytest.mark.parametrize("command", ["validate", "upgrade"])
def test_an_unknown_schema_is_refused_in_one_line_listing_the_known_ones(tmp_path, command):
    path = _write(tmp_path, "schema: 7\nname: x\nrobot: {home_deg: {}}\nreference: {type: hold}\n")
    result = runner.invoke(app, [command, str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert lines == [f"error: {path}: schema: 7 is not a known schema; choose one of: 1 (deprecated), 2 (current)"]


@pytest.mark.parametrize(
    "robot",
    ["{urdf: ../robots/eva.urdf}", "{urdf: ../robots/pr2.urdf}", "{urdf: gone/robot.urdf, home_deg: {j: 1}}"],
    ids=["old-eva-path-at-schema-2", "no-hands", "schema-1-home-deg"],
)
def test_a_missing_urdf_is_reported_as_such_before_anything_about_the_robot(tmp_path, robot):
    schema = "schema: 2\n" if "eva" in robot else ""
    path = _write(tmp_path, f"{schema}name: x\nrobot: {robot}\nreference: {{type: hold}}\n")
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2
    urdf = robot.split()[1].rstrip(",}")
    looked = (path.parent / urdf).resolve()
    expected = f"error: {path}: robot.urdf: {urdf!r} does not exist (looked at {looked})"
    assert result.output.strip().splitlines() == [expected]


def test_upgrade_refuses_a_file_whose_old_field_it_cannot_rewrite_as_written_and_leaves_it(tmp_path):
    text = "eva: &eva ../robots/eva.urdf\nname: x\nrobot: {urdf: *eva}\n"  # the path an alias of another field's
    path = _write(tmp_path, text)
    result = runner.invoke(app, ["upgrade", str(path)])
    assert result.exit_code == 2 and "cannot be rewritten in place" in result.output
    assert (
        "change it by hand: robot.urdf '../robots/eva.urdf' (moved) -> robot.preset: eva; add schema: 2"
        in result.output
    )
    assert path.read_text() == text
