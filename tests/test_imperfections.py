"""Imperfections as scenario fields: off by default they change nothing; written wrong, they get one line."""

import numpy as np
import pytest
from conftest import ROOT, SMOKE, assert_rejected

from harmony_cli.experiment.loop import run_loop
from harmony_cli.experiment.pipeline import build
from harmony_cli.scenario import load_scenario

BOX_LIFT = ROOT / "scenarios/smoke/box_lift.yaml"
PICK_AND_CARRY = ROOT / "scenarios/paper/pick_and_carry.yaml"


def _steps(scenario, layers: bool) -> list[dict]:
    built = build(scenario, BOX_LIFT.parent)
    rows: list[dict] = []
    extra = (built.sensors, built.actuator) if layers else (None, None)
    sim = scenario.sim
    try:
        run_loop(
            built.mpc,
            built.sim,
            built.references,
            sim.duration,
            sim.control_dt,
            sim.substeps,
            rows.append,
            watch=built.watch,
            predict=built.predict,
            sensors=extra[0],
            actuator=extra[1],
        )
    finally:
        built.sim.close()
    return rows


def test_with_every_imperfection_off_a_run_s_steps_are_those_of_a_loop_without_the_sensing_and_actuation_layers():
    scenario = load_scenario(BOX_LIFT, ["sim.duration=4"])
    with_layers, without = _steps(scenario, True), _steps(scenario, False)
    assert len(with_layers) == len(without) == 200
    for a, b in zip(with_layers, without):
        assert a.keys() == b.keys()
        for key in a:
            if not key.endswith("_ms") and key != "wall_clock_s":
                assert (
                    np.array_equal(a[key], b[key], equal_nan=True) if isinstance(a[key], float) else a[key] == b[key]
                ), key


def test_joint_noise_reaches_the_controllers_and_a_latency_is_logged_per_step():
    scenario = load_scenario(
        BOX_LIFT, ["sim.duration=1", "sensing.noise.joint_position.std=0.01", "control.latency=0.008"]
    )
    rows = _steps(scenario, True)
    assert all(row["latency_steps"] == 2 for row in rows)
    clean = _steps(load_scenario(BOX_LIFT, ["sim.duration=1"]), True)
    assert any(a["cmd_q_LARM_JOINT1"] != b["cmd_q_LARM_JOINT1"] for a, b in zip(rows, clean))


def test_an_unknown_box_mass_gives_the_grip_law_the_nominal_mass():
    from harmony_cli.planning.planner import Planner
    from harmony_cli.robot.model import load_robot

    scenario = load_scenario(
        PICK_AND_CARRY, ["world.box.mass=1.4", "world.box.mass_known=false", "world.box.nominal_mass=0.6"]
    )
    planner = Planner(load_robot(scenario.robot, PICK_AND_CARRY.parent), scenario)
    assert planner.grip.law.mass == 0.6
    assert load_scenario(PICK_AND_CARRY, ["world.box.mass=1.4"]).world.box.assumed_mass == 1.4


@pytest.mark.parametrize(
    ("base", "field", "pieces"),
    [
        (BOX_LIFT, "sensing:\n  delay: 0.03\n", ["sensing", "0.03", "sim.control_dt 0.02"]),
        (BOX_LIFT, "control:\n  latency: 0.005\n", ["control", "0.005", "sim.physics_dt 0.004"]),
        (BOX_LIFT, "control:\n  latency: soon\n", ["control.latency", "soon", "measured"]),
        (BOX_LIFT, "sensing:\n  noise:\n    joint_position: {std: -1}\n", ["sensing.noise.joint_position.std", "-1"]),
        (
            SMOKE,
            "world:\n  obstacles:\n  - {name: post, shape: sphere, position: [3, 3, 1], size: [0.2, 0.2, 0.2], "
            "prediction: estimated}\n",
            ["world.obstacles.0", "post", "needs a motion"],
        ),
    ],
)
def test_a_badly_written_imperfection_is_refused_in_one_line_naming_the_field_and_value(tmp_path, base, field, pieces):
    path = tmp_path / "scenario.yaml"
    path.write_text(base.read_text() + field)
    assert_rejected(path, pieces)
