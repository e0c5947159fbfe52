"""The catalogue robots (example-robot-data's URDFs, unedited) do what EVA does, from one scene file each task:
track the S with the whole-body MPC, and pick, carry and place a box with the force loop."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.scenario import load_scenario

runner = CliRunner()
ROBOTS = Path(__file__).resolve().parents[1] / "scenarios" / "robots"
CATALOGUE = ["pr2", "tiago_dual", "baxter"]


def _run(scenario: str, preset: str, out: Path) -> dict:
    result = runner.invoke(
        app, ["run", str(ROBOTS / scenario), "--set", f"robot.preset={preset}", "--out", str(out), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    return json.loads((out / "summary.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("preset", CATALOGUE)
def test_a_catalogue_robot_tracks_the_s_within_3_cm_without_a_failed_solve(preset, tmp_path):
    summary = _run("s_shape.yaml", preset, tmp_path / preset)
    assert summary["failed_solves"] == 0
    assert summary["tracking_error"]["max_m"] <= 0.03, summary["tracking_error"]


@pytest.mark.slow
@pytest.mark.parametrize("preset", CATALOGUE)
def test_a_catalogue_robot_carries_the_box_over_2_m_with_a_turn_and_places_it(preset, tmp_path):
    summary = _run("box_carry.yaml", preset, tmp_path / preset)
    task = summary["task"]
    assert task["success"] and not task["box_dropped"], task
    assert summary["failed_solves"] == 0 and task["planner_failures"] == 0
    assert task["base_yaw_range_deg"] >= 45
    start = load_scenario(tmp_path / preset / "scenario.resolved.yaml").world.box.position
    assert np.linalg.norm(np.subtract(task["box_final"], start)[:2]) >= 2.0
