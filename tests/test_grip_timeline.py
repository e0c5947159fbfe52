"""Where a held box's grip let go (tools/grip_timeline.py): the first layer whose grip width opened before it."""

from __future__ import annotations

import importlib.util
import shutil
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, TABLE1

spec = importlib.util.spec_from_file_location("grip_timeline", ROOT / "tools" / "grip_timeline.py")
assert spec is not None and spec.loader is not None
timeline = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = timeline  # its dataclasses look their module up
spec.loader.exec_module(timeline)

STEPS, LOOSE_AT, OPENS_AT = 40, 30, 20  # rows of a made-up carry: the grip lets go at LOOSE_AT
DT = 0.02


def _hands(robot, q) -> np.ndarray:
    return np.array([p.ravel() for p, _ in robot.hand_poses_numeric(q)])


def _run(tmp_path, robot, reference_opens=0.0, command=None, pressed=False):
    """A run directory whose steps hold the box at home, the pads at their 20 N reference until LOOSE_AT: from
    OPENS_AT on, the hands' references `reference_opens` [m] further apart, the commanded joints `command` (home
    otherwise), the box pressing on the robot if `pressed`."""
    shutil.copy(TABLE1, tmp_path / "scenario.resolved.yaml")
    home = robot.home
    rows = []
    for i in range(STEPS):
        q_cmd = home if command is None or i < OPENS_AT else command
        hands = _hands(robot, home)
        reference = hands + (0.0 if i < OPENS_AT else 0.5 * reference_opens) * np.array([-1, 1])[:, None] * (
            (hands[1] - hands[0]) / np.linalg.norm(hands[1] - hands[0])
        )
        measured = _hands(robot, q_cmd)
        row = {"t": i * DT, "phase": "carry", "holding": True, "planner_status": "stepped"}
        row |= {"box_on_robot_N": 30.0 if pressed and i >= OPENS_AT else 0.0}
        for h, hand in enumerate(robot.hand_names):
            row |= {f"{hand}_force_ref_N": 20.0, f"{hand}_contact_N": 20.0 if i < LOOSE_AT else 4.0}
            row |= {f"{hand}_ref_{a}": reference[h, k] for k, a in enumerate("xyz")}
            row |= {f"{hand}_meas_{a}": measured[h, k] for k, a in enumerate("xyz")}
        row |= {f"cmd_q_{name}": q_cmd[j] for j, name in enumerate(robot.joint_names)}
        rows.append(row)
    pd.DataFrame(rows).to_csv(tmp_path / "steps.csv", index=False)
    return tmp_path


def _opening_command(robot) -> np.ndarray:
    """Home with one arm joint turned so that the hands' forward kinematics are over a millimetre further apart."""
    home, width = robot.home, np.linalg.norm(np.diff(_hands(robot, robot.home), axis=0))
    for name in robot.joint_names:
        if "ARM" not in name:
            continue
        for turn in (0.02, -0.02):
            q = home.copy()
            q[robot.index(name)] += turn
            if np.linalg.norm(np.diff(_hands(robot, q), axis=0)) > width + 1e-3:
                return q
    raise AssertionError("no arm joint opens the grip")  # premise


@pytest.mark.parametrize(
    "case, opened",
    [("reference", "PLAN"), ("command", "COMMAND"), ("pressed", "PRESSED"), ("nothing", "EXECUTION")],
)
def test_the_first_layer_whose_grip_width_opened_before_the_pads_let_go_is_named(tmp_path, eva, case, opened):
    run = _run(
        tmp_path,
        eva,
        reference_opens=2e-3 if case == "reference" else 0.0,
        command=_opening_command(eva) if case == "command" else None,
        pressed=case == "pressed",
    )
    found = timeline.diagnose(run, window=0.3)
    assert found is not None
    assert found.t == pytest.approx(LOOSE_AT * DT)
    assert found.opened is timeline.Opened[opened]


def test_a_grip_that_keeps_its_squeeze_reports_no_loosening(tmp_path, eva):
    run = _run(tmp_path, eva)
    steps = pd.read_csv(run / "steps.csv")
    steps[[f"{h}_contact_N" for h in eva.hand_names]] = 20.0
    steps.to_csv(run / "steps.csv", index=False)
    assert timeline.diagnose(run) is None


def test_a_run_without_a_force_loop_gets_one_line_naming_the_missing_column_and_exit_2(tmp_path, eva, capsys):
    run = _run(tmp_path, eva)
    steps = pd.read_csv(run / "steps.csv").drop(columns=[f"{eva.hand_names[0]}_force_ref_N"])
    steps.to_csv(run / "steps.csv", index=False)
    assert timeline.main([str(run)]) == 2
    message = capsys.readouterr().err.strip()
    assert "\n" not in message and message.startswith(str(run))
    assert f"{eva.hand_names[0]}_force_ref_N" in message
