"""Where the base stands to grip and to place as written: a stance inside a margin is named, with the body and the
turn of the hand targets that would clear it, checked against the base posed by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harmony_cli.maths.shapes import obstacle_shape
from harmony_cli.planning.planner import Planner
from harmony_cli.planning.stance import TOLERANCE, StanceClass, turned
from harmony_cli.planning.stance_check import written_stance_class
from harmony_cli.scenario import load_scenario, robot_of
from harmony_cli.tasks.scene_check import _footprint, planar_gap

PICK_AND_CARRY = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"


def _stances(*overrides: str):
    scenario = load_scenario(PICK_AND_CARRY, list(overrides))
    robot = robot_of(scenario, PICK_AND_CARRY.parent)
    return scenario, robot, {s.pivot: s for s in Planner(robot, scenario).stances}


def _base_gap(scenario, robot, hands: np.ndarray) -> float:
    """The footprint's gap to the cylinder less its margin, the base posed by hand (scene_check's geometry): turned
    with the hands' heading and standing behind their midpoint as at home."""
    home_hands = np.array([p.ravel() for p, _ in robot.hand_poses_numeric(robot.home)])
    x, y, yaw = robot.home[list(robot.base_joints)]

    def heading(pair):
        return np.arctan2(*(pair[1, :2] - pair[0, :2])[::-1])

    turn = heading(hands) - heading(home_hands)
    c, s = np.cos(turn), np.sin(turn)
    behind = np.array([x, y]) - home_hands[:, :2].mean(axis=0)  # the base from the hands' midpoint at home
    at = hands[:, :2].mean(axis=0) + [c * behind[0] - s * behind[1], s * behind[0] + c * behind[1]]
    circles = _footprint(scenario.robot.footprint, [at[0], at[1], np.rad2deg(yaw + turn)])
    cylinder = scenario.world.obstacles[0]
    return min(planar_gap(obstacle_shape(cylinder), circle) for circle in circles) - cylinder.margin


def test_the_paper_scene_s_grip_and_place_stances_are_clear_and_warn_of_nothing():
    _, _, stances = _stances()
    assert set(stances) == {"the box", "the box's goal"}
    assert all(s.margin > 0.0 and s.warning() is None for s in stances.values())


def test_a_cylinder_where_the_base_would_stand_to_place_is_named_with_the_turn_that_clears_it():
    # the cylinder 1.7 m west of the box's goal and a little north: the base, as written, stands inside its margin
    scenario, robot, stances = _stances("world.obstacles.cylinder.position=[4.4, 0.8, 1.0]")
    place = stances["the box's goal"]
    assert place.margin < -TOLERANCE and place.body == "obstacle cylinder" and place.turn_deg is not None
    assert "inside obstacle cylinder's margin" in place.warning() and stances["the box"].warning() is None
    goal = np.asarray(scenario.world.box.goal)
    lower = np.array([[6.1, 0.154, 1.2], [6.1, -0.154, 1.2]])  # the `lower` phase's hands, as written
    moved = turned(lower, goal, np.deg2rad(place.turn_deg))
    # a turn about the goal's vertical: the grip's width, heights and distances from the goal are kept
    np.testing.assert_allclose(np.linalg.norm(moved[1] - moved[0]), 0.308, atol=1e-12)
    np.testing.assert_allclose(moved[:, 2], lower[:, 2])
    np.testing.assert_allclose(np.linalg.norm(moved[:, :2] - goal[:2], axis=1), 0.154, atol=1e-12)
    # the base posed by hand behind each of the group's phases: as deep inside the margin at the deepest as the
    # warning says as written, clear at every one with the turn
    phases = [p for p in scenario.task.phases if p.name in place.phases]
    pairs = [np.array([p.hands["left"], p.hands["right"]], dtype=float) for p in phases]
    assert abs(min(_base_gap(scenario, robot, pair) for pair in pairs) - place.margin) < 1e-9
    turn = np.deg2rad(place.turn_deg)
    assert min(_base_gap(scenario, robot, turned(pair, goal, turn)) for pair in pairs) > -1e-9


def test_a_cylinder_beside_the_pick_stance_is_named_for_the_grip_phases():
    scenario, robot, stances = _stances("world.obstacles.cylinder.position=[3.3, 1.5, 1.0]")
    grip = stances["the box"]
    assert grip.margin < -TOLERANCE and grip.phases[0] == "approach" and "lift" in grip.phases
    box = np.asarray(scenario.world.box.position)
    squeeze = box + np.array([[-0.154, 0.0, 0.08], [0.154, 0.0, 0.08]])
    assert _base_gap(scenario, robot, squeeze) < -TOLERANCE
    if grip.turn_deg is not None:
        assert _base_gap(scenario, robot, turned(squeeze, box, np.deg2rad(grip.turn_deg))) > -1e-9


def test_a_failed_run_s_reason_in_a_study_carries_its_task_warning_or_an_older_run_s_stance_warning():
    from harmony_cli.study.table import run_reason

    task = {"failure": {"category": "dropped", "reason": "the box fell"}}
    assert run_reason({"task": task, "task_warning": "stance: x"}) == "the box fell; stance: x"
    assert run_reason({"task": task, "task_warning": None}) == "the box fell"
    assert run_reason({"status": "failed", "reason": "planner failed", "stance_warning": "stance: x"}) == (
        "planner failed; stance: x"
    )
    assert run_reason({"task": {"failure": None}, "stance_warning": "stance: x"}) is None


def test_a_scene_s_written_stance_class_is_its_worst_stance_s_clear_turned_clear_or_not():
    for cylinder, expected in (
        (None, StanceClass.CLEAR),  # the paper's scene
        ("[4.4, 0.8, 1.0]", StanceClass.TURN_CLEARS),  # beside the place stance: a turn of the place clears it
        ("[5.3, 0.0, 1.0]", StanceClass.NO_TURN_CLEARS),  # where the base stands to place: no turn clears it
    ):
        scenario, robot, stances = _stances(*([f"world.obstacles.cylinder.position={cylinder}"] if cylinder else []))
        assert written_stance_class(scenario, robot) is expected
        blocked = [s for s in stances.values() if s.warning() is not None]  # the planner's own stances agree
        assert bool(blocked) == (expected is not StanceClass.CLEAR)
        assert any(s.turn_deg is None for s in blocked) == (expected is StanceClass.NO_TURN_CLEARS)
