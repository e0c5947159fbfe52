"""The controller's stance search before the robot moves (planning/stance_check.py): a place behind an obstacle's margin
for which no base pose is found ends the run as the controller's failure (`no stance`), not as a refusal by the
scene check, which refuses on proofs only; a blocked stance with a pose found, or one blocked only by where a
moving obstacle starts, is searched and found."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.planning import stance_check
from harmony_cli.planning.stance_check import SEARCH, home_hands, unposed, written_stances
from harmony_cli.scenario import load_scenario, robot_of
from harmony_cli.study.table import NO_STANCE, outcome
from harmony_cli.tasks.scene_check import SceneCheck

PAPER = Path(__file__).resolve().parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"
# the cylinder just in front of the drop table: no room for the base, even inside the cylinder's margin
PLACE_BEHIND = "world.obstacles.cylinder.position=[4.85,0.2,1.0]"
GRIP_BESIDE = "world.obstacles.cylinder.position=[3.2,1.6,1.0]"  # the base stands turned beside it (a pose found)


def test_harmony_run_ends_a_place_no_base_pose_reaches_as_no_stance_in_one_line_naming_the_phases_and_blocker(
    tmp_path,
):
    result = CliRunner().invoke(app, ["run", str(PAPER), "--set", PLACE_BEHIND, "--out", str(tmp_path), "--quiet"])
    assert result.exit_code == 1, result.output
    assert len(result.output.strip().splitlines()) == 1
    assert (
        "no base pose found, clear of the scene (obstacles' margins down to 0.05 m; the trunk out from under table "
        f"tops), from which the hands reach phases carry to retreat at the box's goal ({len(SEARCH)} starts searched"
        in result.output
    )
    assert "inside obstacle cylinder's margin" in result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["failure"] == NO_STANCE and outcome(summary) == NO_STANCE  # a study counts it as a failure


def test_the_scene_check_does_not_refuse_a_place_for_which_the_search_finds_no_stance():
    assert SceneCheck(PAPER.parent)(load_scenario(PAPER, [PLACE_BEHIND])) is None  # a search is not a proof


def test_a_blocked_grip_for_which_a_base_pose_is_found_has_a_stance():
    scenario = load_scenario(PAPER, [GRIP_BESIDE])
    robot = robot_of(scenario, PAPER.parent)
    grip = next(s for s in written_stances(scenario, robot, *home_hands(robot)) if s.pivot == "the box")
    assert grip.warning() is not None  # the written stance is blocked: the search ran
    assert unposed(scenario, robot) is None


def test_a_place_blocked_only_where_a_moving_obstacle_starts_has_a_stance():
    moving = "world.obstacles.cylinder.motion={velocity: [0.0, 0.5, 0.0], start: 0.0, stop: 4.0}"
    scenario = load_scenario(PAPER, [PLACE_BEHIND, moving])
    assert unposed(scenario, robot_of(scenario, PAPER.parent)) is None


def test_the_search_for_a_blocked_place_leaves_out_an_obstacle_that_moves(
    monkeypatch,
):
    both = (
        "world.obstacles=[{name: cylinder, shape: cylinder, position: [4.85, 0.2, 1.0], size: [1.2, 1.2, 2.0], "
        "margin: 0.3}, {name: cart, shape: cylinder, position: [5.2, -0.9, 0.5], size: [0.4, 0.4, 1.0], margin: 0.1, "
        "motion: {velocity: [0.0, 0.5, 0.0], start: 0.0, stop: 4.0}}]"
    )
    scenario = load_scenario(PAPER, [both])
    searched = []  # the scenes the pose search is given (it finds none here: quick)
    monkeypatch.setattr(stance_check, "stance_poses", lambda scene, *a, **k: searched.append(scene) or [])
    why = unposed(scenario, robot_of(scenario, PAPER.parent))
    assert why is not None and [[o.name for o in scene.world.obstacles] for scene in searched] == [["cylinder"]]
