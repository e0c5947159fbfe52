"""A free-handed phase's goal is moved out of the obstacles' margins (planning/clear_goal.py)."""

from pathlib import Path

import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.clear_goal import SPARE, STEP, cleared
from harmony_cli.planning.hand_plan import Obstacle
from harmony_cli.planning.planner import Planner
from harmony_cli.scenario import load_scenario, robot_of

PICK_AND_CARRY = Path(__file__).parents[1] / "scenarios" / "paper" / "pick_and_carry.yaml"

RADIUS, CLEARANCE = 0.3, 0.38  # a cylinder at the origin, a hand's margin + radius about it
CYLINDER = Obstacle(Shape("cylinder", np.array([0.0, 0.0, 1.0]), 0.0, np.array([RADIUS, RADIUS, 1.0])), CLEARANCE)
WIDTH = 0.6  # [m] between the hands, across x


def pair(x: float) -> np.ndarray:
    return np.array([[x, WIDTH / 2, 1.2], [x, -WIDTH / 2, 1.2]])


def test_a_goal_clear_of_every_obstacle_is_kept_as_it_is():
    goal = pair(1.5)
    moved, by, inside = cleared(goal, [CYLINDER])
    assert inside is None and by == 0.0 and np.array_equal(moved, goal)


def test_a_goal_inside_a_margin_moves_by_the_shortest_clear_shift_the_geometry_gives():
    # the pair straddles the x axis: straight out along +x is the shortest way, to hypot(x, w/2) = R + c + spare
    x = 0.45
    shortest = np.sqrt((RADIUS + CLEARANCE + SPARE) ** 2 - (WIDTH / 2) ** 2) - x
    moved, by, inside = cleared(pair(x), [CYLINDER])
    assert inside == 0
    assert shortest <= by < shortest + STEP  # the shifts are tried STEP apart
    assert np.allclose(moved - pair(x), [by, 0.0, 0.0], atol=1e-9)  # rigidly, along the way out
    assert (CYLINDER.shape.distance(moved)[0] >= CLEARANCE).all()


def test_a_goal_that_no_shift_up_to_a_metre_clears_is_kept_and_the_obstacle_named():
    wall = Obstacle(Shape("box", np.array([0.0, 0.0, 1.0]), 0.0, np.array([3.0, 3.0, 1.0])), 0.1)
    goal = pair(0.0)
    moved, by, inside = cleared(goal, [CYLINDER, wall])
    assert inside == 0 and by == 0.0 and np.array_equal(moved, goal)


def test_a_moving_obstacle_is_not_a_reason_to_move_a_goal():
    passing = Obstacle(CYLINDER.shape, CLEARANCE, lambda t: np.outer(t, [1.0, 0.0, 0.0]))
    moved, by, inside = cleared(pair(0.45), [passing])
    assert inside is None and by == 0.0


def test_an_approach_goal_inside_a_cylinder_s_margin_is_said_before_the_robot_moves_and_the_grip_s_is_not():
    # the cylinder 0.75 m east of the approach's right-hand goal: inside its margin, as are the grip's goals at the
    # box, which are not moved (the hands work there: moving them would miss the box)
    scenario = load_scenario(PICK_AND_CARRY)
    box = np.asarray(scenario.world.box.position, dtype=float)
    at = box + [0.3 + 0.75, -0.5, 0.0]
    scenario = load_scenario(PICK_AND_CARRY, [f"world.obstacles.cylinder.position=[{at[0]}, {at[1]}, 1.0]"])
    lines = Planner(robot_of(scenario, PICK_AND_CARRY.parent), scenario).warnings
    assert [line.split("'")[0] for line in lines if line.startswith("goal:")] == ["goal: phase approach"]
