"""Contacts a task must not make (the robot with a table or an obstacle, the box with an obstacle): read from
PyBullet's contact points in a small world (sim/touches.py), then found in a steps table and named in a failure's
reason (report/touches.py, report/task_failure.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import needs_pybullet

from harmony_cli.report.task_failure import task_failure
from harmony_cli.report.touches import touches
from harmony_cli.scenario.world import WorldSpec

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from harmony_cli.sim.touches import Touches
    from harmony_cli.sim.world import World
except ImportError:
    pass

TOP = 1.015  # [m] the table's top
BOX = 0.3  # [m] the box's edge


@pytest.fixture
def client():
    client = BulletClient(connection_mode=pybullet.DIRECT)
    client.setGravity(0, 0, -9.81)
    yield client
    client.disconnect()


def _world(client, post_x: float) -> World:
    """A table, the box resting on it, and a post (a static box obstacle as tall as the box) centred at `post_x`."""
    spec = WorldSpec.model_validate(
        {
            "tables": [{"name": "table", "position": [0.0, 0.0]}],
            "box": {"size": [BOX] * 3, "position": [0.0, 0.0, TOP + BOX / 2]},
            "obstacles": [
                {"name": "post", "shape": "box", "position": [post_x, 0.0, TOP + BOX / 2], "size": [BOX] * 3}
            ],
        }
    )
    return World(client, spec)


def _sphere(client, position, mass: float = 1.0) -> int:
    """A stand-in for the robot: a ball of radius 0.1 m."""
    return client.createMultiBody(mass, client.createCollisionShape(pybullet.GEOM_SPHERE, radius=0.1), -1, position)


def _touches_after_a_step(client, world: World, robot: int) -> Touches:
    touches = Touches(client, robot, world.box, world.tables, world.obstacles)
    client.stepSimulation()
    touches.after_physics_step()
    return touches


@needs_pybullet
def test_the_box_pressed_against_an_obstacle_is_a_contact_and_resting_on_its_table_is_not(client):
    world = _world(client, post_x=BOX - 0.005)  # the post 5 mm into the box's side
    touches = _touches_after_a_step(client, world, robot=_sphere(client, [3.0, 3.0, 0.5], mass=0.0))
    assert list(touches.box_m) == ["post"] and touches.box_m["post"] <= 0.0
    assert touches.robot_m == {}


@needs_pybullet
def test_the_box_a_little_apart_from_an_obstacle_is_no_contact(client):
    """PyBullet reports points up to a few centimetres apart; only those at or inside zero distance count."""
    world = _world(client, post_x=BOX + 0.01)
    touches = _touches_after_a_step(client, world, robot=_sphere(client, [3.0, 3.0, 0.5], mass=0.0))
    assert touches.box_m == {} and touches.robot_m == {}


@needs_pybullet
def test_the_robot_inside_a_table_top_is_a_contact_with_that_table_and_clear_forgets_it(client):
    world = _world(client, post_x=2.0)
    touches = _touches_after_a_step(client, world, robot=_sphere(client, [0.5, 0.0, TOP + 0.09]))  # 1 cm inside
    assert list(touches.robot_m) == ["table"] and touches.robot_m["table"] < 0.0
    touches.clear()
    assert touches.robot_m == {}


def _steps(contact: list[float], clearance: list[float]) -> pd.DataFrame:
    n = len(contact)
    return pd.DataFrame(
        {
            "t": 0.02 * np.arange(n),
            "phase": ["lower"] * n,
            "contact_robot_table_m": contact,
            "contact_robot_post_m": [np.nan] * n,
            "contact_box_post_m": [np.nan] * n,
            "clearance_robot_post_m": clearance,
            "clearance_box_post_m": [0.4] * n,
        }
    )


@needs_pybullet
def test_a_contact_point_and_a_clearance_at_zero_are_both_touches_listed_earliest_first(client):
    nan = np.nan
    steps = _steps([nan, nan, nan, -0.002, -0.004], [0.1, 0.0, 0.05, 0.1, 0.1])
    found = touches(steps, tables={"table"})
    assert [(t["who"], t["body"], t["first_s"], t["steps"]) for t in found] == [
        ("robot", "obstacle post", 0.02, 1),
        ("robot", "table table", 0.06, 2),
    ]
    assert found[1]["deepest_m"] == -0.004 and found[1]["phase"] == "lower"
    assert touches(_steps([nan] * 3, [0.1] * 3), tables={"table"}) == []


def test_a_touch_of_a_table_fails_as_a_collision_at_its_first_step():
    steps = _steps([np.nan, -0.003, -0.001], [0.5] * 3)
    task = {"success": False, "clear_of_obstacles": True, "contact_free": False, "box_dropped": False}
    failure = task_failure(task | {"contacts": touches(steps, tables={"table"})}, steps)
    assert failure["category"] == "collision" and failure["at_s"] == 0.02
    assert failure["reason"].startswith("the robot touched table table at t = 0.02 s (lower)")
