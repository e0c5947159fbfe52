"""The same scenario, seed and machine give bit-identical step logs, every column but the wall-clock ones."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
TIMING = ("_ms", "wall_clock_s")  # wall-clock measurements differ run to run by nature


def test_two_runs_of_a_contact_task_in_separate_processes_log_identical_steps(tmp_path):
    # box_lift up to the squeeze: planner, whole-body MPC with admittance, pads pressing the free box
    harmony = str(Path(sys.executable).with_name("harmony"))
    command = [harmony, "run", str(ROOT / "scenarios/smoke/box_lift.yaml"), "--set", "sim.duration=11", "--quiet"]
    runs = [subprocess.Popen([*command, "--out", str(tmp_path / name)]) for name in ("a", "b")]
    assert [run.wait(timeout=300) for run in runs] == [1, 1]  # 11 s of the task: it fails, the runs complete
    a, b = (pd.read_csv(tmp_path / name / "steps.csv") for name in ("a", "b"))
    assert list(a.columns) == list(b.columns) and len(a) == len(b) == 550
    assert (a["left_contact_N"] > 0).any(), "the pads never touched the box: not a contact run"
    compared = [c for c in a.columns if not c.endswith(TIMING)]
    for column in compared:
        x, y = a[column].to_numpy(), b[column].to_numpy()
        same = np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else (x == y).all()
        assert same, f"{column} differs between the two runs"
