"""The runs of a study: every sample crossed with every grid point, each keyed by a hash of its resolved scenario
and the code version, so a study started again finds the runs it has (and runs again what changed)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from harmony_cli.provenance import code_version
from harmony_cli.scenario import Scenario, scenario_yaml
from harmony_cli.study.sampling import BASE, GridPoint, Sample, Sampler, point_overrides
from harmony_cli.study.spec import StudySpec

KEY_CHARS = 16


@dataclass(frozen=True)
class PlannedRun:
    sample: Sample
    point: GridPoint  # the grid point it runs at (BASE without a grid)
    overrides: list[str]  # everything `harmony run` gets after the base scenario, in order
    key: str  # hash of the resolved scenario and the code version
    duration: float = 0.0  # [s] its simulated duration as written (sim.duration)
    scene: dict[str, Any] = field(default_factory=dict)  # what the sampler's `describe` says of its scenario

    @property
    def label(self) -> str:
        """The grid point's name (`base` without a grid)."""
        return self.point.label

    @property
    def name(self) -> str:
        """The run directory's name: readable, and unique per key."""
        grid = "" if self.point == BASE else f"-{self.label}"
        return f"s{self.sample.index:05d}{grid}-{self.key[:8]}"


def run_key(scenario: Scenario, scenario_path: Path) -> str:
    """A hash of the resolved scenario and the code version. The robot's files count by their content, not where
    they lie, so a study keeps its keys in another checkout or on another machine."""
    resolved = yaml.safe_load(scenario_yaml(scenario))
    robot = resolved["robot"]
    urdf = scenario_path.parent / robot.pop("urdf")
    robot["urdf_sha256"] = hashlib.sha256(urdf.read_bytes()).hexdigest() if urdf.is_file() else str(urdf)
    robot["package_paths"] = len(robot["package_paths"])  # meshes: not hashed (large, and they do not steer)
    text = yaml.safe_dump(resolved, sort_keys=True)
    return hashlib.sha256(f"{text}\0{code_version()}".encode()).hexdigest()[:KEY_CHARS]


def plan_runs(spec: StudySpec, sampler: Sampler, samples: int, progress=None) -> list[PlannedRun]:
    """Every (sample, grid point) run of the first `samples` samples in sample order; `progress(done, total)` after
    each sample."""
    total = samples
    runs = []
    for i in range(total):
        sample = sampler.sample(i)
        for point in sampler.points:
            overrides = sample.overrides + point_overrides(point)
            scenario = sampler.scenario(overrides)
            key = run_key(scenario, sampler.path)
            scene = {} if sampler.describe is None else sampler.describe(scenario)
            runs.append(PlannedRun(sample, point, overrides, key, scenario.sim.duration, scene))
        if progress is not None:
            progress(i + 1, total)
    return runs
