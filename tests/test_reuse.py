"""A long-lived process (a study's worker) builds the whole-body MPC's structure once and reuses it for every later
run of the same structure, and a run that reuses it logs exactly the steps a fresh process logs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.experiment.pipeline import REUSED
from harmony_cli.experiment.run import run_scenario
from harmony_cli.mpc import structures

ROOT = Path(__file__).resolve().parents[1]
BOX_LIFT = ROOT / "scenarios/smoke/box_lift.yaml"
TIMING = ("_ms", "wall_clock_s")  # wall-clock measurements differ run to run by nature
SHORT = ["sim.duration=1.0"]
# another scene of the same structure: what a study varies (the box's mass and place, the robot's start)
OTHER_SCENE = [
    *SHORT,
    "world.box.mass=1.3",
    "world.box.position=[1.39, 0.04, 1.165]",
    "robot.base_pose=[0.03, -0.02, 2.0]",
]


def _same_steps(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns) and len(a) == len(b) == 50
    for column in (c for c in a.columns if not c.endswith(TIMING)):
        x, y = a[column].to_numpy(), b[column].to_numpy()
        same = np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else (x == y).all()
        assert same, f"{column} differs between the run that reused the structure and a fresh process"


def test_a_second_scene_reuses_the_built_structure_and_logs_what_a_fresh_process_logs(tmp_path):
    harmony = str(Path(sys.executable).with_name("harmony"))
    overrides = [arg for o in OTHER_SCENE for arg in ("--set", o)]
    fresh = subprocess.Popen([harmony, "run", str(BOX_LIFT), *overrides, "--quiet", "--out", str(tmp_path / "fresh")])
    try:
        structures.forget_structures()  # whatever earlier tests built here: the first run below builds its own
        built_before = structures.builds
        first = run_scenario(BOX_LIFT, SHORT, tmp_path / "first", progress=False, plots="none")
        second = run_scenario(BOX_LIFT, OTHER_SCENE, tmp_path / "second", progress=False, plots="none")
    finally:
        assert fresh.wait(timeout=300) == 1  # a short run of the task: it fails, the run completes
    assert structures.builds == built_before + 1, "the second scene built the whole-body MPC's structure again"
    summaries = [json.loads((run / "summary.json").read_text()) for run in (first, second)]
    assert [s["status"] for s in summaries] == ["completed", "completed"]
    assert summaries[1]["build_time_s"] < 0.25 * summaries[0]["build_time_s"]
    assert REUSED not in (first / "run.log").read_text() and REUSED in (second / "run.log").read_text()
    steps = [pd.read_csv(run / "steps.csv") for run in (first, second, tmp_path / "fresh")]
    assert not steps[0]["q_base_x"].equals(steps[1]["q_base_x"])  # another scene: other steps
    _same_steps(steps[1], steps[2])
