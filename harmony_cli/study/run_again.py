"""The command that runs one of a study's runs again from files a checkout has: the base scenario and the draw's
overrides (the run directory's overrides.yaml), into the run directory the study used. A study's run directories
are not committed with its report; this command makes one where it is missing, `harmony view` then replays it."""

from __future__ import annotations

import os
import shlex
from pathlib import Path

from harmony_cli.experiment.run_dir import read_inputs


def run_again(run_dir: str | Path) -> str:
    """`harmony run BASE --set KEY=VALUE ... --out RUN_DIR` for the run in `run_dir` (the base scenario relative to
    the working directory where it lies under it); the resolved scenario's command where overrides.yaml is gone."""
    run_dir = Path(run_dir)
    inputs = read_inputs(run_dir)
    if inputs is None:
        return shlex.join(["harmony", "run", str(run_dir / "scenario.resolved.yaml")])
    scenario, overrides = inputs
    if scenario.is_absolute() and scenario.is_relative_to(Path.cwd()):
        scenario = Path(os.path.relpath(scenario))
    words = ["harmony", "run", str(scenario)]
    for item in overrides:
        words += ["--set", item]
    return shlex.join([*words, "--out", str(run_dir)])
