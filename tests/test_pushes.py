"""Scripted pushes: YAML validation, the impulse PyBullet receives, the push and force metrics on synthetic step
tables, and a short closed-loop run and compare table with a push on a hand."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import ROOT, assert_rejected, needs_pybullet
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.report.metrics import displacement_from_twin, force_outcome, push_outcome, recovery_time
from harmony_cli.robot.urdf import hand_below
from harmony_cli.scenario import BoxSpec, PushSpec, SimSpec, WorldSpec, load_scenario

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    from harmony_cli.sim.bullet import BulletSimulation
except ImportError:
    pass

runner = CliRunner()
BOX_LIFT = ROOT / "scenarios/smoke/box_lift.yaml"
EVA = ROOT / "harmony_cli/robot/presets/eva.urdf"
HEAD = "name: x\nrobot: {preset: eva}\nreference: {type: hold}\n"
WITH_BOX = (
    HEAD + "world: {box: {position: [3, 0, 1]}, obstacles: [{name: post, shape: box, position: [5, 0, 1], "
    "size: [0.1, 0.1, 2]}]}\n"
)


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            WITH_BOX + "pushes: [{name: p, body: cart, force: [1, 0, 0], start: 1, duration: 1}]\n",
            ["pushes.0.body", "'cart'", "robot, box, post"],
        ),
        (
            WITH_BOX + "pushes: [{name: p, body: robot, link: LARM_TOOLS, force: [1, 0, 0], start: 1, duration: 1}]\n",
            ["pushes.0.link", "'LARM_TOOLS'", "closest (of 26): LARM_TOOL, RARM_TOOL"],
        ),
        (
            WITH_BOX + "pushes: [{name: p, body: box, link: base, force: [1, 0, 0], start: 1, duration: 1}]\n",
            ["pushes.0.link", "only a push on the robot"],
        ),
        (
            WITH_BOX + "pushes: [{name: p, body: box, force: [1, 0, 0], start: 1, duration: 1},\n"
            "         {name: p, body: robot, force: [1, 0, 0], start: 2, duration: 1}]\n",
            ["pushes.1.name", "'p'", "unique"],
        ),
        (
            WITH_BOX + "pushes: [{name: p, body: box, force: [1, 0, 0], start: 1, duration: 0}]\n",
            ["pushes.0.duration", "greater than 0"],
        ),
        (WITH_BOX + "pushes: [{name: p, body: box, force: [1, 0], start: 1, duration: 1}]\n", ["pushes.0.force"]),
        (
            WITH_BOX + "pushes: [{name: p, body: box, force: [1, 0, 0], start: 1, duration: 1, frame: link}]\n",
            ["pushes.0.frame", "unknown key", "name, body, link, point, force, start, duration"],
        ),
        (
            HEAD + "pushes: [{name: p, body: box, force: [1, 0, 0], start: 1, duration: 1}]\n",
            ["pushes.0.body", "'box'", "choose one of: robot"],
        ),
    ],
)
def test_a_bad_push_gets_one_line_naming_file_field_value_and_choices(tmp_path, text, expected):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert_rejected(path, expected)


def test_a_valid_push_loads_with_its_defaults(tmp_path):
    path = tmp_path / "ok.yaml"
    path.write_text(
        WITH_BOX + "pushes: [{name: shove, body: robot, link: LARM_TOOL, force: [0, 40, 0], start: 2, duration: 0.5}]\n"
    )
    push = load_scenario(path).pushes[0]
    assert push.point is None and push.force == (0, 40, 0)
    hands = {"left": "LARM_grasp", "right": "RARM_grasp"}
    assert hand_below(push.link, EVA, hands) == "left"
    assert hand_below("CHEST", EVA, hands) is None


MASS = 0.8


@pytest.fixture
def free_box_sim(eva):
    """A box in the air far from the robot, undamped, pushed forward and then twisted at an offset point."""
    pushes = [
        PushSpec(name="shove", body="box", force=(8.0, 0.0, 0.0), start=0.1, duration=0.2),
        PushSpec(name="twist", body="box", point=(0.0, 0.1, 0.0), force=(1.0, 0.0, 0.0), start=0.4, duration=0.02),
    ]
    world = WorldSpec(box=BoxSpec(position=(3.0, 0.0, 2.0), mass=MASS))
    sim = BulletSimulation(eva, SimSpec(), world, pushes)
    sim.client.changeDynamics(sim.world.box, -1, linearDamping=0.0, angularDamping=0.0)
    yield sim
    sim.close()


@needs_pybullet
def test_a_push_on_a_free_body_gives_the_impulse_f_t_over_m_only_inside_its_window(free_box_sim):
    sim, dt = free_box_sim, free_box_sim.spec.control_dt
    expected, measured, logged = [], [], []
    for step in range(25):  # 0.5 s: vx(t) = F / m * clamp(t - start, 0, duration) (+ the twist's own push)
        t = step * dt
        logged.append(sim.pushes.magnitudes(t)["push_shove_N"])
        sim.step(sim.spec.substeps)
        velocity, _ = sim.client.getBaseVelocity(sim.world.box)
        measured.append(velocity[0])
        expected.append(8.0 / MASS * np.clip(t + dt - 0.1, 0, 0.2) + 1.0 / MASS * np.clip(t + dt - 0.4, 0, 0.02))
    assert measured[3] == pytest.approx(0.0, abs=1e-9)  # nothing before the push starts at 0.1 s
    np.testing.assert_allclose(measured, expected, rtol=0.01, atol=1e-6)
    assert measured[-1] == pytest.approx(8.0 * 0.2 / MASS + 1.0 * 0.02 / MASS, rel=0.01)  # 2.025 m/s
    assert logged == [8.0 if 0.1 - 1e-9 <= i * dt < 0.3 - 1e-9 else 0.0 for i in range(25)]
    # the twist acts 0.1 m beside the centre: torque (0, 0.1, 0) x (1, 0, 0) = -0.1 N m about z for 0.02 s
    size = np.array(BoxSpec(position=(0, 0, 0)).size)
    inertia_z = MASS / 12 * (size[0] ** 2 + size[1] ** 2)
    _, spin = sim.client.getBaseVelocity(sim.world.box)
    assert spin[2] == pytest.approx(-0.1 * 0.02 / inertia_z, rel=0.02)


@needs_pybullet
def test_a_push_on_a_hand_is_an_external_force_its_wrist_sensor_reads(eva):
    push = PushSpec(name="press", body="robot", link="LARM_TOOL", force=(0.0, 0.0, -20.0), start=0.0, duration=1.0)
    sim = BulletSimulation(eva, SimSpec(), None, [push])
    try:
        for _ in range(25):
            sim.apply(eva.home, np.zeros(eva.n_dof))
            sim.step(sim.spec.substeps)
        obs = sim.observe()
    finally:
        sim.close()
    world_force = [obs.hand_rotations[h] @ obs.wrenches[h, :3] for h in range(2)]
    np.testing.assert_allclose(world_force[0], [0, 0, -20], atol=1.0)
    np.testing.assert_allclose(world_force[1], [0, 0, 0], atol=0.2)


def test_recovery_needs_the_error_to_stay_within_1_cm_for_half_a_second():
    t = np.arange(0, 4, 0.02)
    error = np.where(t < 1.0, 0.0, np.interp(t, [1.0, 1.5, 2.5], [0.0, 0.03, 0.002]))
    # linear fall from 3 cm at 1.5 s to 0.2 cm at 2.5 s crosses 1 cm at 1.5 + 2 / 2.8 = 2.214 s: first sample 2.22
    assert recovery_time(t, error, 1.0) == pytest.approx(1.22)
    error[(t > 2.5) & (t < 2.6)] = 0.015  # back out before 0.5 s have passed: recovery starts again at 2.6
    assert recovery_time(t, error, 1.0) == pytest.approx(1.6)
    assert recovery_time(t, np.full_like(t, 0.02), 1.0) is None
    assert recovery_time(t[t < 3.05], error[t < 3.05], 1.0) is None  # the log ends before 0.5 s have passed


def _steps(n: int = 500, dt: float = 0.02) -> pd.DataFrame:
    """Synthetic steps: squeeze (ramp to 20 N) then carry (20 N), a push on the left hand at 6 s."""
    t = np.arange(n) * dt
    ref = np.clip((t - 2.0) / 2.0, 0, 1) * 20.0
    wobble = np.where(np.arange(n) % 2, 2.0, -2.0)  # +-2 N around the reference
    frame = {"step": np.arange(n), "t": t, "phase": np.where(t < 4.0, "squeeze", "carry")}
    for hand in ("left", "right"):
        frame |= {
            f"{hand}_force_ref_N": ref,
            f"{hand}_force_normal_N": ref + wobble,
            f"{hand}_error_m": np.full(n, 0.001),
        }
        frame |= {f"{hand}_meas_{a}": np.zeros(n) for a in "xyz"}
    frame["left_force_normal_N"] = frame["left_force_normal_N"] + np.where(np.isclose(t, 7.02), 10.0, 0.0)
    frame["left_error_m"] = np.where((t >= 6.0) & (t < 7.0), 0.02, 0.001)
    frame["push_shove_N"] = np.where((t >= 6.0 - 1e-9) & (t < 6.5 - 1e-9), 40.0, 0.0)
    return pd.DataFrame(frame)


def test_squeeze_force_error_is_reported_per_phase_over_steps_with_a_reference():
    out = force_outcome(_steps(), ["left", "right"])
    assert out["phases_with_reference"] == ["squeeze", "carry"]
    carry, squeeze = out["phases"]["carry"], out["phases"]["squeeze"]
    assert carry["right"]["rms_N"] == pytest.approx(2.0) and carry["right"]["max_N"] == pytest.approx(2.0)
    n = carry["left"]["steps"]
    assert n == 300 and carry["left"]["max_N"] == pytest.approx(12.0)  # the 10 N spike on top of the +2 N wobble
    assert carry["left"]["rms_N"] == pytest.approx(np.sqrt(((n - 1) * 4 + 144) / n))
    assert squeeze["left"]["steps"] == 99  # 2.02 .. 3.98 s: the ramp's first step (ref 0) is left out
    assert out["rms_N"] == out["overall"]["left"]["rms_N"] > out["overall"]["right"]["rms_N"]  # the worse hand
    assert force_outcome(_steps().drop(columns=["left_force_ref_N"]), ["left", "right"]) is None


def test_push_outcome_compares_the_push_window_with_the_baseline_before_it():
    steps = _steps()
    push = PushSpec(name="shove", body="robot", link="LARM_TOOL", force=(0, 40, 0), start=6.0, duration=0.5)
    out = push_outcome(steps, [push], ["left", "right"], {"shove": "left"})["shove"]
    assert out["applied_impulse_N_s"] == pytest.approx(20.0)
    assert out["push"]["window_s"] == [6.0, 8.5] and out["baseline"]["window_s"] == [3.5, 6.0]
    assert out["push"]["displacement_from"] == "reference"
    assert out["peak_displacement_m"] == pytest.approx(0.02) and out["baseline"]["peak_displacement_m"][
        "left"
    ] == pytest.approx(0.001)
    assert out["recovery_s"] == pytest.approx(1.0)  # back within 1 cm at 7.0 s and stays
    assert out["baseline"]["recovery_s"] == pytest.approx(0.0)
    assert out["peak_pad_force_N"] == pytest.approx(32.0)  # 20 N + 2 N wobble + the 10 N spike at 7.02 s
    assert out["baseline"]["peak_pad_force_N"]["right"] == pytest.approx(22.0)
    # with a push-free twin the displacement comes from it: the twin sits 3 cm lower from 6.4 s to 6.8 s
    twin = steps.copy()
    twin.loc[(twin["t"] > 6.39) & (twin["t"] < 6.8), ["left_meas_z", "right_meas_z"]] = -0.03
    twin = twin[twin["t"] < 9.0]  # it ended early: no displacement known later
    with_twin = displacement_from_twin(steps, twin, ["left", "right"])
    assert with_twin["left_push_displacement_m"].max() == pytest.approx(0.03)
    assert with_twin["left_push_displacement_m"].iloc[-1] != with_twin["left_push_displacement_m"].iloc[-1]  # NaN
    out = push_outcome(with_twin, [push], ["left", "right"], {"shove": None})["shove"]
    assert out["push"]["displacement_from"] == "push-free run"
    assert out["peak_displacement_m"] == pytest.approx(0.03) and out["recovery_s"] == pytest.approx(0.8)


def _box_lift_with_a_push(tmp_path: Path, start: float, duration: float) -> Path:
    raw = yaml.safe_load(BOX_LIFT.read_text())
    raw["robot"] = {"preset": "eva"}
    raw["pushes"] = [
        {
            "name": "left",
            "body": "robot",
            "link": "LARM_TOOL",
            "force": [0.0, 0.0, -30.0],
            "start": start,
            "duration": duration,
        }
    ]
    path = tmp_path / "box_lift_push.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_a_closed_loop_run_with_a_push_logs_it_measures_it_against_its_push_free_twin_and_plots_it(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(
        app,
        [
            "run",
            str(_box_lift_with_a_push(tmp_path, 1.0, 0.4)),
            "--out",
            str(out),
            "--quiet",
            "--set",
            "sim.duration=3.0",
        ],
    )
    assert result.exit_code == 1, result.output  # 3 s of the task: it fails (phases never started), the run completes
    assert sum(line.startswith("push left ") for line in result.output.splitlines()) == 1  # a line per push
    steps = pd.read_csv(out / "steps.csv")
    inside = (steps["t"] >= 1.0 - 1e-9) & (steps["t"] < 1.4 - 1e-9)
    assert (steps["push_left_N"][inside] == 30.0).all() and (steps["push_left_N"][~inside] == 0.0).all()
    before = steps["t"] < 1.0
    assert (steps["left_push_displacement_m"][before] == 0.0).all()  # the twin is the same run up to the push
    summary = json.loads((out / "summary.json").read_text())
    push = summary["task"]["pushes"]["left"]
    assert summary["push_free_twin"]["status"] == "completed"
    assert push["pushed_hand"] == "left" and push["applied_impulse_N_s"] == pytest.approx(12.0)
    # the stiff arm servo yields only ~0.1 mm to 30 N on a free hand, but any push shows against the exact twin
    assert push["peak_displacement_m"] > 1e-5 and push["baseline"]["peak_displacement_m"]["left"] == 0.0
    for name in ("force_tracking.png", "push_left.png", "push_free/steps.csv"):
        assert (out / name).exists(), name


@pytest.mark.slow  # 16 s (a compare grid of closed-loop runs)
def test_compare_tabulates_push_metrics_per_grid_point(tmp_path):
    out = tmp_path / "cmp"
    result = runner.invoke(
        app,
        [
            "compare",
            str(_box_lift_with_a_push(tmp_path, 0.6, 0.2)),
            "--grid",
            "planner.period=1,2",
            "--set",
            "sim.duration=1.4",
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "table.csv", index_col=0)
    assert [c for c in table.columns if "[period-1]" in c] and [c for c in table.columns if "[period-2]" in c]
    for row in (
        "Push left: peak displacement (baseline)",
        "Push left: peak pad force (baseline)",
        "Push left: recovery to 1 cm",
        "Task success",
    ):
        assert row in table.index, row
        assert table.loc[row].notna().all() and (table.loc[row] != "").all(), table.loc[row]
    assert all(cell.endswith("(0.000 cm)") for cell in table.loc["Push left: peak displacement (baseline)"])
    # an ablation that keeps the transcription and K has no paper column and says what it varies
    assert not [c for c in table.columns if c.endswith("paper")]
    assert (out / "table.md").read_text().startswith("# Ablation over planner.period (")


@needs_pybullet
def test_a_spring_pusher_presses_with_its_set_force_on_what_does_not_give_and_less_on_what_does(eva):
    """A free box (0.8 kg, undamped) against m x'' = k (s(t) - x) integrated independently, and a static post
    (it cannot give) against the full |force| once the tip has travelled |force| / k."""
    k, force, start, duration = 200.0, 4.0, 0.1, 0.4
    pushes = [
        PushSpec(name="spring", body="box", force=(force, 0.0, 0.0), start=start, duration=duration, stiffness=k),
        PushSpec(name="wall", body="post", force=(0.0, -force, 0.0), start=start, duration=duration, stiffness=k),
    ]
    world = WorldSpec(
        box=BoxSpec(position=(3.0, 0.0, 2.0), mass=MASS),
        obstacles=[{"name": "post", "shape": "box", "position": [5, 0, 1], "size": [0.1, 0.1, 2]}],
    )
    sim = BulletSimulation(eva, SimSpec(), world, pushes)
    try:
        sim.client.changeDynamics(sim.world.box, -1, linearDamping=0.0, angularDamping=0.0)
        x0 = sim.client.getBasePositionAndOrientation(sim.world.box)[0][0]
        logged = []
        for step in range(int(round((start + duration) / sim.spec.control_dt))):
            sim.step(sim.spec.substeps)
            logged.append(sim.pushes.magnitudes(step * sim.spec.control_dt))
        x_sim = sim.client.getBasePositionAndOrientation(sim.world.box)[0][0] - x0
    finally:
        sim.close()
    travel = lambda t: force / k * np.clip((t - start) / (duration / 4), 0.0, 1.0)
    x, v, h = 0.0, 0.0, 1e-5
    for t in np.arange(start, start + duration, h):
        v += h * k * max(0.0, travel(t) - x) / MASS
        x += h * v
    assert x_sim == pytest.approx(x, rel=0.03)
    assert max(row["push_spring_N"] for row in logged) < 0.9 * force  # the box gives way
    assert logged[-1]["push_wall_N"] == pytest.approx(force)  # the post does not
