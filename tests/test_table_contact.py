"""A closed-loop run whose hands are sent into the table fails as a collision with the table (PyBullet's contact
points, sim/touches.py); the same scene with the hands aimed where they should be touches nothing. The smoke
box lift's first two phases (raise 3 s, approach 4 s), so each run takes seconds."""

import pandas as pd
import pytest
from conftest import ROOT, assert_exit_follows_outcome
from typer.testing import CliRunner

from harmony_cli.cli import app

runner = CliRunner()
BOX_LIFT = ROOT / "scenarios" / "smoke" / "box_lift.yaml"
SHORT = ["--set", "sim.duration=8.0"]  # raise and approach
# the approach's hands 0.25 m below the box's centre: 0.1 m below the table's top, beside the box
INTO_TABLE = [
    f"task.phases.approach.hands.{hand}.offset=[0.0, {y}, -0.25]" for hand, y in (("left", 0.3), ("right", -0.3))
]


def _run(out, overrides: list[str]) -> dict:
    sets = [arg for o in overrides for arg in ("--set", o)]
    result = runner.invoke(app, ["run", str(BOX_LIFT), "--out", str(out), "--quiet", *SHORT, *sets])
    return assert_exit_follows_outcome(result, out)["task"]


@pytest.fixture(scope="module")
def into_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("into_table") / "run"
    return _run(out, INTO_TABLE), pd.read_csv(out / "steps.csv")


def test_hands_pressed_into_the_table_fail_the_run_as_a_collision_with_the_table(into_table):
    task, steps = into_table
    assert task["success"] is False and task["contact_free"] is False
    assert task["failure"]["category"] == "collision"
    assert [(c["who"], c["body"]) for c in task["contacts"]] == [("robot", "table table")]
    first = task["contacts"][0]["first_s"]
    assert task["failure"]["at_s"] == first and first >= 3.0  # in the approach, after the raise
    assert steps.loc[steps["t"] == first, "contact_robot_table_m"].iloc[0] <= 0.0


def test_an_approach_held_off_its_goal_by_the_table_re_plans_its_stance_and_times_out_after_both_waits(into_table):
    """The approach (4 s) waits 4 s, searches a stance of its own as it would give up, waits 4 s more in vain."""
    task, _ = into_table
    approach = next(p for p in task["phases"] if p["name"] == "approach")
    assert approach["timed_out"] and task["timed_out_phases"] == ["approach"]
    assert approach["restanced_s"] == pytest.approx(approach["start_s"] + 4.0 + 4.0, abs=0.05)
    assert approach["late_s"] == pytest.approx(8.0) and task["late_s"] == pytest.approx(approach["late_s"])


def test_the_same_scene_with_the_hands_aimed_beside_the_box_touches_no_table(tmp_path):
    task = _run(tmp_path / "run", [])
    assert task["contacts"] == [] and task["contact_free"] is True
    assert (task["failure"] or {}).get("category") != "collision"
