"""The push-free twin of a scenario with pushes: the same scenario without them, run up to the last push's window
end. The loop is deterministic, so each hand's distance from its twin at the same step is what the pushes did
(a task's live reference re-plans from the measured pose, so the tracking error hides a push)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.experiment.pipeline import RunFailed, execute
from harmony_cli.experiment.run_dir import write_inputs
from harmony_cli.report.metrics import AFTER_PUSH_S
from harmony_cli.scenario import Scenario


def push_free(scenario: Scenario) -> tuple[Scenario, list[str]]:
    """The twin scenario and the overrides that make it from the original."""
    dt = scenario.sim.control_dt
    until = max(p.start + p.duration for p in scenario.pushes) + AFTER_PUSH_S
    duration = float(min(scenario.sim.duration, dt * np.ceil(until / dt - 1e-9)))
    twin = scenario.model_copy(update={"pushes": [], "sim": scenario.sim.model_copy(update={"duration": duration})})
    return twin, ["pushes=[]", f"sim.duration={duration!r}"]


def run_push_free_twin(
    path: Path, overrides: list[str], scenario: Scenario, out: Path, progress: bool, concurrency: int
) -> tuple[pd.DataFrame | None, dict]:
    """Run the twin into `out` (a run directory of its own); its steps, or None with why if it failed."""
    twin, extra = push_free(scenario)
    write_inputs(out, path, list(overrides) + extra, twin)
    try:
        execute(twin, path.parent, out, progress, concurrency)
    except RunFailed as exc:
        return None, {"dir": str(out), "status": "failed", "error": str(exc)}
    return pd.read_csv(out / "steps.csv"), {"dir": str(out), "status": "completed", "duration_s": twin.sim.duration}
