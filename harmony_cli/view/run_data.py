"""What a replay reads from a run directory alone: steps.csv, scenario.resolved.yaml (the robot, tables, box and
obstacles), replay.npz (knots and plans, when the run wrote one) and the robot's prepared URDF (the cache, made
again from the resolved scenario when it is not there)."""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from harmony_cli.cache import CACHE_DIR
from harmony_cli.experiment.replay_log import REPLAY
from harmony_cli.robot.model import urdf_plan
from harmony_cli.robot.prepare import prepare_urdf
from harmony_cli.scenario import Scenario, ScenarioError, load_scenario


class NotARun(ValueError):
    """A directory a replay cannot be made from (one line naming it)."""


@dataclass
class RunData:
    path: Path
    scenario: Scenario
    steps: pd.DataFrame
    arrays: dict[str, np.ndarray]  # replay.npz's columns ({} for runs made before it existed)
    urdf: Path  # the prepared URDF (planar base joints added: steps.csv's q_* columns name its joints)

    @property
    def hands(self) -> list[str]:
        return list(self.scenario.robot.end_effectors)

    @property
    def times(self) -> np.ndarray:
        return self.steps["t"].to_numpy()

    @property
    def control_dt(self) -> float:
        """[s] between two logged steps (every control step is logged)."""
        return self.scenario.sim.control_dt

    def joints(self, i: int) -> dict[str, float]:
        """The measured joint positions at step i, by joint name."""
        row = self.steps.iloc[i]
        return {c[2:]: float(row[c]) for c in self.steps.columns if c.startswith("q_")}

    def base_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """The base's logged x and y per step (its planar joints, by the scenario's names)."""
        x, y = self.scenario.robot.base_joints[:2]
        return self.column(f"q_{x}", 0.0), self.column(f"q_{y}", 0.0)

    def column(self, name: str, default: float = np.nan) -> np.ndarray:
        return self.steps[name].to_numpy(dtype=float) if name in self.steps else np.full(len(self.steps), default)


def load_run(path: Path) -> RunData:
    """A run directory's replay data; NotARun when it has no steps.csv or resolved scenario, or they are unreadable."""
    steps_csv, resolved = path / "steps.csv", path / "scenario.resolved.yaml"
    if not path.is_dir() or not steps_csv.is_file() or not resolved.is_file():
        raise NotARun(f"{path}: not a run directory (needs steps.csv and scenario.resolved.yaml)")
    try:
        scenario = load_scenario(resolved, runnable=False)
        steps = pd.read_csv(steps_csv)
    except (ScenarioError, ValueError, OSError) as exc:
        raise NotARun(f"{path}: cannot read its run files: {str(exc).splitlines()[0]}") from exc
    if len(steps) == 0 or "t" not in steps:
        raise NotARun(f"{path}: steps.csv has no steps")
    arrays = {}
    if (path / REPLAY).is_file():
        try:  # a run killed while writing it leaves a truncated file
            with np.load(path / REPLAY) as npz:
                arrays = {name: npz[name][: len(steps)] for name in npz.files}
        except (ValueError, OSError, zipfile.BadZipFile) as exc:
            raise NotARun(f"{path}: cannot read {REPLAY}: {str(exc).splitlines()[0]}") from exc
    spec = scenario.robot
    prepared = prepare_urdf(
        (resolved.parent / spec.urdf).resolve(), urdf_plan(spec, resolved.parent), CACHE_DIR / "urdf"
    )
    return RunData(path, scenario, steps, arrays, prepared.path)


def load_runs(paths: list[Path]) -> list[RunData]:
    """Several runs of one scene (same tables, box and obstacles' shapes); NotARun naming the odd one out."""
    runs = [load_run(p) for p in paths]
    first = runs[0]
    for run in runs[1:]:
        if _scene(run.scenario) != _scene(first.scenario):
            raise NotARun(
                f"{run.path}: not the scene of {first.path} (tables, box or obstacles differ): overlay needs one"
            )
    return runs


def _scene(scenario: Scenario) -> tuple:
    """What must match for runs to be overlaid: the tables and the box, and the obstacles by name and shape."""
    world = scenario.world
    return (
        [t.model_dump() for t in world.tables],
        None if world.box is None else (tuple(world.box.size),),
        [(o.name, o.shape, tuple(o.size)) for o in world.obstacles],
    )
