"""The arms' clearance rows left unevaluated where a bound shows they cannot bind (mpc/far_rows.py): the bound's
lever arms against the arms' exact Jacobians, the bound's decisions, and a closed-loop run whose commands are those
of the solver that evaluates every row (the same QP optimum: equal to rounding)."""

from __future__ import annotations

import casadi as cs
import numpy as np
import pandas as pd
import pytest
from conftest import ROOT

from harmony_cli.experiment.run import run_scenario
from harmony_cli.mpc.clearance import arm_points
from harmony_cli.mpc.far_rows import FarBound, FarRows
from harmony_cli.scenario import load_scenario, robot_of

ROBOTS = ROOT / "scenarios" / "robots" / "box_carry.yaml"
STATIC = ROOT / "scenarios" / "paper" / "static_obstacles.yaml"


@pytest.mark.parametrize("preset", ["eva", "pr2", "tiago_dual", "baxter"])
def test_no_arm_point_moves_faster_per_unit_of_a_joint_than_its_lever_bound(preset):
    scenario = load_scenario(ROBOTS, [f"robot.preset={preset}"])
    robot = robot_of(scenario, ROBOTS.parent)
    q = cs.SX.sym("q", robot.n_dof)
    rng = np.random.default_rng(1)
    levers = np.zeros(robot.n_dof)
    for chain in robot.arms:
        for name, lever in chain.levers:
            levers[robot.index(name)] = max(levers[robot.index(name)], lever)
    points = cs.vertcat(*[cs.vertcat(*ps) for ps in arm_points(robot, q) if ps])
    speeds = cs.Function("speeds", [q], [cs.jacobian(points, q)])
    bounded = np.isfinite(robot.lower) & np.isfinite(robot.upper) & (robot.upper - robot.lower < 100)
    for _ in range(50):
        x = robot.home.copy()
        x[bounded] = rng.uniform(robot.lower[bounded], robot.upper[bounded])
        J = np.array(speeds(x)).reshape(-1, 3, robot.n_dof)  # (points, xyz, joints)
        fastest = np.linalg.norm(J, axis=1).max(axis=0)  # per joint, the fastest point
        assert np.all(fastest <= levers + 1e-9), (preset, fastest - levers)


def _bound(h: float = 0.1) -> tuple[FarBound, np.ndarray, np.ndarray]:
    """A far row of one body (centre rows 0-2, yaw row 3 of 4 parameter rows) whose arm moves 0.5 m per radian
    of joint 0 and 1 m per metre of joint 1, stored h at q = 0 over 3 knots."""
    bound = FarBound(FarRows(np.array([0.5, 1.0, 0.0]), np.array([[0, 1, 2, 3]])))
    q, ref = np.zeros((3, 3)), np.zeros((4, 3))
    bound.store(q, ref, np.full((3, 1), h))
    return bound, q, ref


def test_a_far_row_is_clear_while_the_joints_and_the_step_cannot_use_up_its_margin():
    bound, q, ref = _bound(0.1)
    moved = q.copy()
    moved[0] = 0.1  # 5 cm by the lever
    step = np.zeros((3, 3))
    step[1] = 0.04  # 4 cm more at most
    assert bound.clear(moved, ref, step)
    step[1] = 0.06  # 11 cm: it might bind
    assert not bound.clear(moved, ref, step)
    moved[2] = 10.0  # a joint that moves no arm point
    assert bound.clear(moved, ref, np.zeros((3, 3)))


def test_a_far_row_whose_body_moved_or_turned_is_clear_only_within_what_the_move_leaves():
    bound, q, ref = _bound(0.1)
    nearer = ref.copy()
    nearer[0] = 0.08
    assert bound.clear(q, nearer, np.zeros((3, 3)))
    nearer[0] = 0.12
    assert not bound.clear(q, nearer, np.zeros((3, 3)))
    turned = ref.copy()
    turned[3] = 1e-3
    assert not bound.clear(q, turned, np.zeros((3, 3)))


def test_a_far_row_never_evaluated_is_not_clear():
    bound = FarBound(FarRows(np.ones(3), np.array([[0, 1, 2, 3]])))
    assert not bound.clear(np.zeros((3, 3)), np.zeros((4, 3)), np.zeros((3, 3)))


def _steps(out, monkeypatch, evaluate_every_row: bool) -> pd.DataFrame:
    """A short closed-loop run's steps, with how often the far rows were evaluated (attrs["far_evaluations"])."""
    calls = {"far": 0}
    store = FarBound.store

    def counted(self, q, ref, h):
        calls["far"] += 1
        store(self, q, ref, h)

    monkeypatch.setattr(FarBound, "store", counted)
    if evaluate_every_row:
        monkeypatch.setattr(FarBound, "clear", lambda self, q, ref, step: False)
    run_scenario(STATIC, ["sim.duration=8"], out, progress=False, plots="none")
    steps = pd.read_csv(out / "steps.csv")
    steps.attrs["far_evaluations"] = calls["far"]
    return steps


@pytest.fixture(scope="module")
def screened_and_every(tmp_path_factory) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The same run with the far rows left out where the bound shows them clear, and with every row evaluated."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        screened = _steps(tmp_path_factory.mktemp("screened"), monkeypatch, evaluate_every_row=False)
    with pytest.MonkeyPatch.context() as monkeypatch:
        every = _steps(tmp_path_factory.mktemp("every"), monkeypatch, evaluate_every_row=True)
    return screened, every


def test_leaving_the_far_rows_out_where_they_cannot_bind_changes_no_command(screened_and_every):
    screened, every = screened_and_every
    assert screened.attrs["far_evaluations"] < 0.5 * len(screened)  # most steps leave them out
    assert every.attrs["far_evaluations"] >= len(every)
    commands = [c for c in screened.columns if c.startswith("cmd_q")]
    pd.testing.assert_frame_equal(screened[commands], every[commands], check_exact=False, rtol=0.0, atol=1e-9)


def test_the_violation_logged_with_the_far_rows_left_out_is_the_one_with_every_row(screened_and_every):
    screened, every = screened_and_every
    assert every["constraint_violation"].max() > 0.0  # the rows linearised: a step leaves some violation
    np.testing.assert_allclose(screened["constraint_violation"], every["constraint_violation"], rtol=0, atol=1e-9)
