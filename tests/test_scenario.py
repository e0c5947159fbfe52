"""Scenario files: every shipped YAML validates; bad input gets one line naming file, field, value, choices."""

import json
from pathlib import Path

import pytest
from conftest import ROOT, TABLE1, assert_rejected
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.scenario import ScenarioError, apply_overrides, load_scenario

SHIPPED = sorted(p for p in (ROOT / "scenarios").rglob("*.yaml"))
runner = CliRunner()


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_shipped_scenario_is_valid(path):
    load_scenario(path)


def test_shipped_scenarios_exist():
    assert any("paper" in str(p) for p in SHIPPED) and any("smoke" in str(p) for p in SHIPPED)


def test_overrides_set_nested_values_parsed_as_yaml():
    s = load_scenario(TABLE1, ["mpc.knots=6", "mpc.transcription=traditional", "solver.options={ipopt.tol: 1.0e-7}"])
    assert s.mpc.knots == 6 and s.mpc.transcription == "traditional"
    assert s.solver.options == {"ipopt.tol": 1e-7}


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace("urdf: URDF", f"preset: eva, urdf: {ROOT / 'harmony_cli/robot/presets/eva.urdf'}"))
    return path


BASE = "name: x\nrobot: {urdf: URDF}\nreference: {type: hold}\n"


@pytest.mark.parametrize(
    "text, expected",
    [
        (BASE + "mpc: {transcripton: bezier}\n", ["mpc.transcripton", "'bezier'", "transcription, integration"]),
        (BASE + "mpc: {transcription: bezeir}\n", ["mpc.transcription", "'bezeir'", "'bezier' or 'traditional'"]),
        (BASE + "solver: {name: knitro}\n", ["solver.name", "'knitro'", "ipopt", "rti"]),
        (BASE + "solver: {qp: cplex}\n", ["solver.qp", "'cplex'", "'auto'"]),
        (BASE + "sim: {physics_dt: 0.0041666667, control_dt: 0.02}\n", ["sim.control_dt", "0.02", "whole multiple"]),
        (BASE + "mpc: {knots: 1}\n", ["mpc.knots", "1", "greater than or equal to 2"]),
        (
            "name: x\nrobot: {urdf: URDF}\nreference: {type: circle}\n",
            ["reference.type", "'circle'", "'s_curve'", "'hold'"],
        ),
        ("name: x\nrobot: {urdf: URDF}\n", ["reference", "missing"]),
        (
            "name: x\nrobot: {urdf: URDF, base_joints: [base_x, base_y, base_z]}\nreference: {type: hold}\n",
            ["robot.base_joints", "'base_z'", "base_x"],
        ),
        (
            "name: x\nrobot: {preset: eva, urdf: nowhere.urdf}\nreference: {type: hold}\n",
            ["robot.urdf", "nowhere.urdf"],
        ),
        ("name: [unclosed\n", ["not valid YAML"]),
        (
            "name: x\nrobot: {urdf: URDF}\ntask: {phases: [{name: a, duration: 1, hands: {left: {relative_to: shelf, "
            "offset: [0, 0, 0]}, right: null}}]}\n",
            ["task.phases.0.hands.left.relative_to", "'shelf'", "(none)"],
        ),
        (
            "name: x\nrobot: {urdf: URDF}\ntask: {phases: [{name: a, duration: 1, hands: {left: [1, 2, 3]}}]}\n",
            ["task.phases.0.hands", "left, right"],
        ),
        (
            BASE + "world: {obstacles: [{name: o, shape: cone, position: [0, 0, 0], size: [1, 1, 1]}]}\n",
            ["world.obstacles.0.shape", "'cone'", "'cylinder'"],
        ),
        (
            "name: x\nrobot: {urdf: URDF}\nreference: {type: hold}\ntask: {phases: [{name: a, duration: 1, hands: "
            "{left: null, right: null}}]}\n",
            ["reference / task", "both given"],
        ),
    ],
)
def test_bad_file_gets_one_line_naming_file_field_value_and_choices(tmp_path, text, expected):
    path = _write(tmp_path, text)
    assert_rejected(path, expected)


def test_malformed_set_is_rejected():
    with pytest.raises(ScenarioError, match="expected key.path=value"):
        apply_overrides({}, ["mpc.knots"])


def test_cli_validate_bad_file_exits_2_with_one_line_and_no_traceback(tmp_path):
    path = _write(tmp_path, BASE + "mpc: {transcription: bezeir}\n")
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "mpc.transcription" in lines[0]


def test_cli_run_with_bad_override_exits_2(tmp_path):
    result = runner.invoke(app, ["run", str(TABLE1), "--set", "mpc.knots=zero", "--out", str(tmp_path / "r")])
    assert result.exit_code == 2 and "mpc.knots" in result.output and "Traceback" not in result.output


def test_cli_schema_is_json_schema_with_every_section():
    result = runner.invoke(app, ["schema"])
    schema = json.loads(result.output)
    assert {"robot", "reference", "mpc", "solver", "sim"} <= set(schema["properties"])
