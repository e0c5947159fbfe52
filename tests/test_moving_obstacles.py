"""Moving obstacles: the motion in YAML, the PyBullet body following it, both MPCs getting its predicted centre at
their own times, the logged track and the summary."""

import json
import shutil

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, TABLE1, assert_rejected, needs_pybullet
from matplotlib.colors import to_rgb
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.experiment.run import run_scenario
from harmony_cli.maths.shapes import Shape, obstacle_shape
from harmony_cli.mpc import wholebody
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Obstacle
from harmony_cli.scenario import ObstacleSpec, PlannerSpec, ScenarioError, WorldSpec, load_scenario
from harmony_cli.tasks.motion import centre_at, obstacle_predictor

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet

    from harmony_cli.sim.bullet import BulletSimulation
except ImportError:
    pass

runner = CliRunner()
BOX = ROOT / "scenarios" / "smoke" / "box_lift.yaml"
DYNAMIC = ROOT / "scenarios" / "paper" / "dynamic_obstacle.yaml"


def _obstacle(motion, position=(0.0, 0.0, 1.0)) -> ObstacleSpec:
    return ObstacleSpec.model_validate(
        {"name": "o", "shape": "cylinder", "position": position, "size": [0.4, 0.4, 2.0], "motion": motion}
    )


def test_constant_velocity_moves_between_start_and_stop_and_holds_outside():
    o = _obstacle({"velocity": [0.5, -0.2, 0.0], "start": 1.0, "stop": 3.0}, position=(1.0, 2.0, 1.0))
    centres = centre_at(o, [0.0, 1.0, 2.0, 3.0, 10.0])
    np.testing.assert_allclose(
        centres, [[1.0, 2.0, 1.0], [1.0, 2.0, 1.0], [1.5, 1.8, 1.0], [2.0, 1.6, 1.0], [2.0, 1.6, 1.0]]
    )


def test_waypoints_interpolate_linearly_and_hold_their_ends():
    o = _obstacle({"waypoints": [[1.0, 0.0, 0.0, 1.0], [3.0, 2.0, 0.0, 1.0], [4.0, 2.0, -1.0, 1.0]]}, None)
    assert o.position == (0.0, 0.0, 1.0)  # defaults to the centre at t = 0 (held first waypoint)
    centres = centre_at(o, [-2.0, 1.0, 2.0, 3.5, 4.0, 9.0])
    np.testing.assert_allclose(centres, [[0, 0, 1], [0, 0, 1], [1, 0, 1], [2, -0.5, 1], [2, -1, 1], [2, -1, 1]])


def test_a_static_obstacle_is_where_it_stands_and_predicts_nothing():
    o = _obstacle(None, position=(1.0, 2.0, 1.0))
    np.testing.assert_allclose(centre_at(o, [0.0, 5.0]), [[1.0, 2.0, 1.0]] * 2)
    assert obstacle_predictor([o]) is None
    moving = _obstacle({"velocity": [1.0, 0.0, 0.0]})
    assert obstacle_predictor([o, moving])(np.array([0.0, 2.0])).shape == (2, 2, 3)


OBSTACLE = "world: {obstacles: [{name: o, shape: cylinder, size: [0.4, 0.4, 2], %s}]}\n"


@pytest.mark.parametrize(
    "fields, expected",
    [
        (
            "position: [0, 0, 1], motion: {velocity: [0, 1, 0], start: 2, stop: 1}",
            ["world.obstacles.0.motion.stop", "1", "must be after start (2 s)"],
        ),
        (
            "motion: {waypoints: [[0, 0, 0, 1], [2, 1, 0, 1], [1, 1, 1, 1]]}",
            ["world.obstacles.0.motion.waypoints", "strictly increasing", "waypoint 2 at t = 1 s follows t = 2 s"],
        ),
        ("position: [0, 0, 1], motion: {}", ["world.obstacles.0.motion", "exactly one of velocity", "waypoints"]),
        (
            "position: [0, 0, 1], motion: {velocity: [0, 1, 0], waypoints: [[0, 0, 0, 1], [1, 1, 0, 1]]}",
            ["world.obstacles.0.motion", "exactly one of velocity"],
        ),
        (
            "position: [0, 0, 1], motion: {waypoints: [[0, 0, 0, 1], [1, 1, 0, 1]], start: 1}",
            ["world.obstacles.0.motion", "start / stop go with velocity"],
        ),
        (
            "position: [1, 0, 1], motion: {waypoints: [[0, 0, 0, 1], [1, 1, 0, 1]]}",
            ["world.obstacles.0", "not the waypoints' centre at t = 0", "[0.0, 0.0, 1.0]"],
        ),
        (
            "position: [0, 0, 1], motion: {waypoints: [[0, 0, 0, 1]]}",
            ["world.obstacles.0.motion.waypoints", "at least 2"],
        ),
        (
            "position: [0, 0, 1], motion: {speed: 1}",
            ["world.obstacles.0.motion.speed", "velocity, start, stop, waypoints"],
        ),
    ],
)
def test_bad_motion_gets_one_line_naming_file_field_value_and_what_is_valid(tmp_path, fields, expected):
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nrobot: {preset: eva}\nreference: {type: hold}\n" + OBSTACLE % fields)
    assert_rejected(path, expected)


def test_a_list_index_in_an_override_freezes_the_moving_obstacle():
    moving = load_scenario(DYNAMIC).world.obstacles[1]
    frozen = load_scenario(DYNAMIC, ["world.obstacles.1.motion=null"]).world.obstacles[1]
    assert moving.motion is not None and frozen.motion is None and frozen.position == moving.position
    with pytest.raises(ScenarioError, match="'7' is not an index of a list of 2"):
        load_scenario(DYNAMIC, ["world.obstacles.7.motion=null"])


@needs_pybullet
def test_the_pybullet_body_is_where_the_motion_says_and_closest_points_see_it_there(eva):
    spec = WorldSpec.model_validate(
        {
            "obstacles": [
                {
                    "name": "walker",
                    "shape": "cylinder",
                    "position": [1.5, -1.0, 1.0],
                    "size": [0.4, 0.4, 2.0],
                    "motion": {"velocity": [0.0, 0.5, 0.0], "start": 0.1, "stop": 0.5},
                }
            ]
        }
    )
    sim = BulletSimulation(eva, load_scenario(TABLE1).sim, spec)
    world, walker = sim.world, spec.obstacles[0]
    probe = sim.client.createMultiBody(
        0, sim.client.createCollisionShape(pybullet.GEOM_SPHERE, radius=1e-3), -1, [1.5, 0.0, 1.0]
    )
    try:
        seen = []
        for _ in range(40):  # 0.8 s: still, moving, stopped
            seen.append((sim.time, world.obstacle_position("walker"), world.clearance(probe, "walker")))
            sim.step(5)
        for t, position, clearance in seen:
            np.testing.assert_allclose(position, centre_at(walker, t)[0], atol=1e-9)
            expected = abs(position[1]) - 0.2 - 1e-3  # probe at y = 0, cylinder radius 0.2
            assert clearance == pytest.approx(expected, abs=2e-3)  # Bullet's 1 mm collision margins
        assert {round(p[1], 6) for _, p, _ in seen} >= {-1.0, -0.8}  # moved 0.2 m in y, held before and after
    finally:
        sim.close()


@pytest.fixture(scope="module")
def moving_run(tmp_path_factory):
    """box_lift for 1 s with an obstacle walking past, with every whole-body MPC parameter vector recorded."""
    params = []
    original = wholebody.WholeBodyMPC.step

    def recording_step(self, q_now, hand_ref, *forces):
        out = original(self, q_now, hand_ref, *forces)
        params.append((self.params.copy(), self.problem.ref_shape, self.knot_times.copy(), self.layout))
        return out

    walker = (
        "world.obstacles=[{name: walker, shape: cylinder, position: [0.6, -1.2, 1.0], size: [0.4, 0.4, 2.0], "
        "margin: 0.1, motion: {velocity: [0.3, 0.2, 0.0]}}, "
        "{name: post, shape: box, position: [-2.0, 2.0, 1.0], size: [0.2, 0.2, 2.0]}]"
    )
    out = tmp_path_factory.mktemp("moving") / "run"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(wholebody.WholeBodyMPC, "step", recording_step)
        run_scenario(BOX, [walker, "sim.duration=1.0"], out, progress=False)
    return out, params, load_scenario(out / "scenario.resolved.yaml")


def test_the_whole_body_mpc_gets_the_obstacle_at_t_plus_its_knot_times(moving_run):
    out, params, scenario = moving_run
    walker, dt = scenario.world.obstacles[0], scenario.sim.control_dt
    assert len(params) == 50
    for step, (p, shape, knot_times, layout) in enumerate(params):
        rows = p.reshape(shape, order="F")
        centre = rows[layout.obstacle_centre(0)]
        np.testing.assert_allclose(centre.T, centre_at(walker, step * dt + knot_times), atol=1e-12)
        np.testing.assert_allclose(rows[layout.obstacle_yaw(0)], 0.0)
    first, last = (p.reshape(s, order="F")[layout.obstacle_centre(0)] for p, s, _, layout in (params[0], params[-1]))
    assert not np.allclose(first, last)  # the prediction moved with time


def test_the_obstacle_track_and_its_min_clearance_are_logged(moving_run):
    out, _, scenario = moving_run
    steps = pd.read_csv(out / "steps.csv")
    track = steps[[f"obstacle_walker_{a}" for a in "xyz"]].to_numpy()
    np.testing.assert_allclose(track, centre_at(scenario.world.obstacles[0], steps["t"]), atol=1e-9)
    # PyBullet's robot clearance is at most each hand's: the grasp frames lie on the pads' surfaces (Bullet's
    # collision margins: 1 mm per body)
    walker = obstacle_shape(scenario.world.obstacles[0])
    for hand in ("left", "right"):
        hands = steps[[f"{hand}_meas_{a}" for a in "xyz"]].to_numpy()
        to_hand = np.array(
            [walker.distance((p - centre + walker.centre)[None])[0][0] for p, centre in zip(hands, track)]
        )
        assert np.all(steps["clearance_robot_walker_m"] <= to_hand + 2e-3)
    task = json.loads((out / "summary.json").read_text())["task"]
    assert set(task["min_clearance_moving_m"]) == {"walker"} and set(task["min_clearance_m"]) == {"walker", "post"}
    assert task["min_clearance_moving_m"]["walker"]["robot"] == pytest.approx(steps["clearance_robot_walker_m"].min())


def test_paths_command_overlays_runs_of_one_scene(moving_run, tmp_path):
    out, *_ = moving_run
    other = tmp_path / "again"
    shutil.copytree(out, other)
    image = tmp_path / "paths.png"
    result = runner.invoke(app, ["paths", str(out), str(other), "--out", str(image)])
    assert result.exit_code == 0, result.output
    pixels = (plt.imread(image)[..., :3] * 255).round()
    drawn = [
        (np.abs(pixels - 255 * np.array(to_rgb(colour))).max(axis=2) <= 2).sum()
        for colour in plt.rcParams["axes.prop_cycle"].by_key()["color"][:3]
    ]
    assert drawn[0] > 50 and drawn[1] > 50 and drawn[2] == 0, drawn  # a colour per run: two runs, not three
    result = runner.invoke(app, ["paths", str(tmp_path), "--out", str(image)])
    assert result.exit_code == 2 and "no steps.csv" in result.output


def test_the_planner_keeps_clear_of_where_a_crossing_obstacle_will_be():
    """Hands from x = 0.76 to 2.76 in 5 s; an obstacle crosses their straight path at x = 1.7 around t = 2.5 s.
    Parked where it starts, it is far away and the plan is straight; moving, the plan keeps clear of it at every
    sample time, so it is not the straight one."""
    start = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
    goal, spec = start + [2.0, 0.0, 0.0], PlannerSpec()
    shape = Shape("cylinder", np.array([1.7, -2.5, 1.0]), 0.0, np.array([0.25, 0.25, 1.0]))
    crossing = lambda times: shape.centre + np.outer(np.asarray(times), [0.0, 1.0, 0.0])  # y = 0 at t = 2.5 s
    plans = {}
    for name, motion in (("parked", None), ("moving", crossing)):
        planner = HandMPC(spec, [Obstacle(shape, 0.2, motion)], np.stack([np.eye(3)] * 2), np.pi / 2)
        result = planner.step(0.0, HandState(start, np.zeros((2, 3)), 0.0), goal, 5.0, 0)
        assert result.success
        times = np.linspace(0.0, result.plan.horizon, spec.samples + 1)[1:]
        positions, _ = result.plan.sample(times)
        plans[name] = positions
        centres = crossing(times) if motion else np.tile(shape.centre, (times.size, 1))
        for hand in range(2):
            distance, _ = Shape(shape.kind, np.zeros(3), 0.0, shape.half).distance(positions[:, hand] - centres)
            assert distance.min() >= 0.2 - 5e-3, (name, distance.min())
    assert np.abs(plans["parked"][:, :, 1] - start[:, 1]).max() < 1e-3  # straight in y
    assert np.abs(plans["moving"] - plans["parked"]).max() > 0.1


@pytest.fixture(scope="module")
def dynamic_runs(tmp_path_factory):
    """dynamic_obstacle.yaml closed loop, as shipped and with the obstacle parked where it starts."""
    root = tmp_path_factory.mktemp("dynamic")
    runs = {}
    for label, overrides in (("moving", []), ("parked", ["world.obstacles.1.motion=null"])):
        out = run_scenario(DYNAMIC, overrides, root / label, progress=False)
        runs[label] = (json.loads((out / "summary.json").read_text()), pd.read_csv(out / "steps.csv"))
    return runs


@pytest.mark.slow
def test_dynamic_obstacle_succeeds_clear_of_the_moving_obstacle(dynamic_runs):
    summary, _ = dynamic_runs["moving"]
    task = summary["task"]
    assert task["success"], task
    crosser = task["min_clearance_moving_m"]["crosser"]
    assert crosser["robot"] > 0 and crosser["box"] > 0
    assert all(v > 0 for c in task["min_clearance_m"].values() for v in c.values())


@pytest.mark.slow
def test_the_obstacle_s_motion_changes_the_robot_s_path(dynamic_runs):
    assert dynamic_runs["parked"][0]["task"]["success"]
    moving, parked = (steps[["q_base_x", "q_base_y"]].to_numpy() for _, steps in dynamic_runs.values())
    assert np.linalg.norm(moving - parked, axis=1).max() > 0.2  # [m] apart at the same time
