"""Samples of a study: sample i is drawn from its own random stream (a numpy Generator seeded with the study's
seed and i), so it is the same whatever the number of samples; a draw the scene check or the scenario's
validation refuses is drawn again from that stream, and counted.

A draw becomes `--set` overrides of the base scenario, so whatever is defined relative to a varied field
follows it: hand targets `relative_to: box` move with the box, a table's targets with the table, and
`robot.base_pose` is where the robot starts."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from harmony_cli.scenario import ScenarioError, load_scenario
from harmony_cli.scenario.models import Scenario
from harmony_cli.study.spec import Distribution, StudySpec


@dataclass(frozen=True)
class Sample:
    draws: str  # the set of draws it belongs to (dev, validation, ...)
    seed: int  # that set's seed
    index: int
    values: dict[str, Any]  # varied field -> its value in this scene
    overrides: list[str]  # the base scenario's --set (the study's own first), this sample's, in that order
    rejected: list[str] = field(default_factory=list)  # why each earlier draw of this sample was refused


def value_at(data: Any, key: str) -> Any:
    """The value at a dotted key in a scenario's mapping (lists by index or by their items' names)."""
    node = data
    for part in key.split("."):
        if isinstance(node, list):
            names = [i.get("name") if isinstance(i, dict) else None for i in node]
            node = node[int(part)] if part.isdigit() and int(part) < len(node) else node[names.index(part)]
        else:
            node = node[part]
    return node


def draw(dist: Distribution, rng: np.random.Generator, base: Any = None) -> Any:
    """One value of a distribution (plain Python: floats, lists, ints, the chosen item)."""
    kind = dist.kind
    if kind == "choice":
        assert dist.choice is not None
        return dist.choice[int(rng.integers(len(dist.choice)))]
    if kind == "integers":
        assert dist.integers is not None
        value: Any = int(rng.integers(dist.integers[0], dist.integers[1], endpoint=True))
    else:
        low, high = (np.asarray(v, dtype=float) for v in getattr(dist, kind))
        drawn = rng.normal(low, high) if kind == "normal" else rng.uniform(low, high)
        if kind == "yaw_deg":
            drawn = (drawn + 180.0) % 360.0 - 180.0
        value = np.asarray(drawn).tolist()
    if dist.relative:
        value = (np.asarray(base, dtype=float) + np.asarray(value, dtype=float)).tolist()
    return value


def override(key: str, value: Any) -> str:
    """`key=value` as `--set` takes it (the value as one-line YAML)."""
    return f"{key}={yaml.safe_dump(value, default_flow_style=True, width=1 << 16).strip().removesuffix('...').strip()}"


@dataclass(frozen=True)
class GridPoint:
    """One setting every draw runs at: the fields it sets (field -> value) and its name (`base`: no grid)."""

    label: str
    values: dict[str, Any]


BASE = GridPoint("base", {})


def grid_points(spec: StudySpec) -> list[GridPoint]:
    """The points of the grid's product, or the named points, or [BASE] with neither."""
    if spec.points:
        return [GridPoint(name, values) for name, values in spec.points.items()]
    keys = list(spec.grid)
    points = [dict(zip(keys, values, strict=True)) for values in itertools.product(*spec.grid.values())]
    return [GridPoint(point_label(point), point) if point else BASE for point in points]


def point_label(point: dict[str, Any]) -> str:
    return "_".join(f"{k.split('.')[-1]}-{v}" for k, v in point.items()) or "base"


class Sampler:
    """Draws the samples of one set of draws (`seed`) of a study over its base scenario; `check(scenario)` returns
    why a scene is impossible (None: possible). A sample is a scene for every grid point, so each point's scenario
    passes the check. `describe(scenario)` gives what a report breaks a run's outcome down by ({} without it)."""

    def __init__(
        self, spec: StudySpec, scenario_path: Path, check=None, draws: tuple[str, int] = ("dev", 0), describe=None
    ):
        self.spec, self.path, self.check, self.describe = spec, scenario_path, check, describe
        self.draws, self.seed = draws
        self.points = grid_points(spec)
        self.notices: list[str] = []  # a base scenario of an older schema: its deprecation notice
        self.base = load_scenario(scenario_path, spec.set, self.notices)
        self.base_values = self.base.model_dump(mode="json")
        for key, dist in spec.vary.items():  # every varied field exists (and a relative one is a number or vector)
            try:
                base = value_at(self.base_values, key)
            except (KeyError, ValueError, IndexError, TypeError):
                raise ScenarioError(f"vary: {key!r} is not a field of the base scenario {scenario_path}") from None
            if dist.relative and not _numeric(base):
                raise ScenarioError(f"vary.{key}: relative needs a number or vector there, not {base!r}")

    def scenario(self, overrides: list[str]) -> Scenario:
        return load_scenario(self.path, overrides)

    def sample(self, index: int) -> Sample:
        rng = np.random.default_rng([self.seed, index])
        rejected: list[str] = []
        for _ in range(self.spec.check.max_tries):
            values = {key: draw(d, rng, value_at(self.base_values, key)) for key, d in self.spec.vary.items()}
            overrides = list(self.spec.set) + [override(k, v) for k, v in values.items()]
            why = self._refusal(overrides)
            if why is None:
                return Sample(self.draws, self.seed, index, values, overrides, rejected)
            rejected.append(why)
        raise ScenarioError(
            f"sample {index}: no possible scene in {self.spec.check.max_tries} draws (check.max_tries); "
            f"the last was refused: {rejected[-1]}"
        )

    def _refusal(self, overrides: list[str]) -> str | None:
        """Why a draw is not a scene (at some grid point), or None."""
        for point in self.points:
            try:
                scenario = self.scenario(overrides + point_overrides(point))
            except ScenarioError as exc:
                return f"invalid: {str(exc).removeprefix(f'{self.path}: ')}"
            why = self.check(scenario) if self.check is not None and self.spec.check.enabled else None
            if why is not None:
                return why
        return None


def point_overrides(point: GridPoint) -> list[str]:
    return [override(k, v) for k, v in point.values.items()]


def _numeric(value: Any) -> bool:
    try:
        return np.asarray(value, dtype=float).ndim <= 1
    except (TypeError, ValueError):
        return False
