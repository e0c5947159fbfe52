"""A study file: a base scenario, named sets of draws (a seed and a number of samples each), distributions over
scenario fields and optional grid axes crossed with them. Read through the same gate as scenarios (one line per
mistake).

Sets of draws keep development and reporting apart: `dev` is for finding and diagnosing failures, `validation` is
run to report and never to choose between variants, and a test set whose seed is not in the file is run with
`--draws test --seed S --samples N` on what lands."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import Field, PositiveInt, ValidationError, model_validator

from harmony_cli.scenario.base import Strict
from harmony_cli.scenario.errors import ScenarioError, one_line
from harmony_cli.scenario.loading import grid_axis
from harmony_cli.scenario.source import load_yaml_file

MAX_SAMPLES = 100_000
KINDS = ("uniform", "normal", "choice", "integers", "yaw_deg")
NAME = re.compile(r"[A-Za-z0-9_.-]+")  # a name that is also part of a run directory's name

Value = float | list[float]


class Distribution(Strict):
    """One of: `uniform: [low, high]` (numbers or vectors of one length), `normal: [mean, std]` (likewise),
    `choice: [a, b, ...]` (any values, equally likely), `integers: [low, high]` (both included), `yaw_deg:
    [low, high]` (an angle drawn in degrees, wrapped into [-180, 180)). `relative: true` adds the draw to the base
    scenario's value (numbers and vectors)."""

    uniform: tuple[Value, Value] | None = None
    normal: tuple[Value, Value] | None = None
    choice: list[Any] | None = Field(None, min_length=1)
    integers: tuple[int, int] | None = None
    yaw_deg: tuple[float, float] | None = None
    relative: bool = Field(False, description="add the draw to the base scenario's value")

    @model_validator(mode="after")
    def _one_kind(self) -> Distribution:
        given = [k for k in KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of {', '.join(KINDS)} (got {', '.join(given) or 'none'})")
        low, high = getattr(self, given[0]) if given[0] != "choice" else (0, 0)
        if isinstance(low, list) != isinstance(high, list) or (
            isinstance(low, list) and isinstance(high, list) and len(low) != len(high)
        ):
            raise ValueError(f"{given[0]}: {low!r} and {high!r} must both be numbers or vectors of one length")
        if given[0] == "normal":
            if min(high if isinstance(high, list) else [high]) < 0:
                raise ValueError(f"normal: the standard deviation {high!r} must be >= 0")
        elif given[0] != "choice" and any(h < lo for lo, h in _pairs(low, high)):
            raise ValueError(f"{given[0]}: low {low!r} is above high {high!r}")
        if self.relative and given[0] == "choice":
            raise ValueError("relative: a choice is a value, not an offset")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in KINDS if getattr(self, k) is not None)


def _pairs(low: Value, high: Value) -> list[tuple[float, float]]:
    if isinstance(low, list) and isinstance(high, list):
        return list(zip(low, high, strict=True))
    return [(float(low), float(high))]  # type: ignore[arg-type]


class DrawSet(Strict):
    """One set of draws: sample i of it is drawn from a stream seeded with (seed, i)."""

    seed: int = Field(ge=0)
    samples: PositiveInt = Field(le=MAX_SAMPLES)


class SceneCheck(Strict):
    """Impossible samples are rejected and drawn again (sample i keeps its own random stream)."""

    enabled: bool = True
    max_tries: PositiveInt = Field(100, le=10_000, description="draws per sample before the study is refused")
    clearance: float = Field(0.0, ge=0, description="extra gap every obstacle keeps from tables and the box [m]")


class Paired(Strict):
    """One setting against another on the same draws: grid field `field` at `a` against `b` (`point`: named grid
    points), every other grid field held."""

    field: str = Field(description="a grid field, or `point` for the grid points by name")
    a: Any
    b: Any
    statistic: Literal["ratio", "difference"] = Field(
        "ratio", description="per draw a / b, their median; or a - b, their mean; each with a bootstrap interval"
    )

    @property
    def no_effect(self) -> float:
        """The statistic's value when the settings do not differ: a ratio of 1, a difference of 0."""
        return 1.0 if self.statistic == "ratio" else 0.0


class Claim(Strict):
    """A metric the report states per grid point (its median, with a bootstrap interval) and, with `paired`, as a
    paired comparison."""

    name: str
    metric: str = Field(description="a study.parquet column, e.g. summary.solve_time_ms.median or success")
    scale: float = Field(1.0, description="the metric's values are multiplied by this in the report")
    unit: str = ""
    paired: Paired | None = None


class StudySpec(Strict):
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$", description="also the default output directory's name")
    description: str = ""
    scenario: str = Field(description="the base scenario file, relative to the study file")
    set: list[str] = Field([], description="overrides applied to the base scenario, as `--set` takes them")
    draws: dict[str, DrawSet] = Field(
        min_length=1, description="named sets of draws, e.g. dev and validation; the first is the default"
    )
    vary: dict[str, Distribution] = Field(
        {}, description="scenario field (dotted; list items by index or name) -> its distribution"
    )
    grid: dict[str, list[Any]] = Field({}, description="scenario field -> values, each crossed with every sample")
    points: dict[str, dict[str, Any]] = Field(
        {},
        description="instead of a grid: named settings (name -> scenario field -> value), each run on every sample",
    )
    check: SceneCheck = SceneCheck()
    claims: list[Claim] = Field([], description="metrics stated with intervals, and paired comparisons (report.md)")

    @model_validator(mode="before")
    @classmethod
    def _one_set(cls, raw):
        """`samples:` and `seed:` at the top level (a file with one set of draws) are the set `dev`."""
        if isinstance(raw, dict) and "draws" not in raw and "samples" in raw:
            raw = dict(raw)
            raw["draws"] = {"dev": {"seed": raw.pop("seed", 0), "samples": raw.pop("samples")}}
        return raw

    @model_validator(mode="after")
    def _axes(self) -> StudySpec:
        if self.grid and self.points:
            raise ValueError("give a grid or named points, not both")
        for name, sets in self.points.items():
            if not NAME.fullmatch(name) or name == "base":
                raise ValueError(f"point name {name!r}: letters, digits, '_', '.', '-' only, and not 'base'")
            if clash := next((k for k in sets if k in self.vary), None):
                raise ValueError(f"point {name!r}: {clash!r} is both varied and set by the point; choose one")
        for key, values in self.grid.items():
            if not values:
                raise ValueError(f"grid {key!r} has no values")
            if key in self.vary:
                raise ValueError(f"{key!r} is both varied and a grid axis; choose one")
        for claim in self.claims:
            paired = claim.paired
            if paired is not None and paired.field == "point":
                if missing := [v for v in (paired.a, paired.b) if v not in self.points]:
                    raise ValueError(f"claim {claim.name!r}: {missing[0]!r} is not a named point ({list(self.points)})")
            elif paired is not None:
                axis = self.grid.get(paired.field)
                if axis is None:
                    raise ValueError(f"claim {claim.name!r}: {paired.field!r} is not a grid field ({_axes(self)})")
                if missing := [v for v in (paired.a, paired.b) if v not in axis]:
                    raise ValueError(f"claim {claim.name!r}: {missing[0]!r} is not a value of grid {paired.field!r}")
        return self


def _axes(spec: StudySpec) -> str:
    return "the grid has " + (", ".join(spec.grid) or "none")


def draw_set(spec: StudySpec, name: str | None, seed: int | None, samples: int | None) -> tuple[str, DrawSet]:
    """The set of draws to run: `name` from the file (None: its first), its seed or number of samples replaced when
    given; a name the file does not have needs both (ScenarioError otherwise)."""
    name = name or next(iter(spec.draws))
    written = spec.draws.get(name)
    if written is None and (seed is None or samples is None):
        raise ScenarioError(
            f"--draws {name}: not a set of the study file (it has {', '.join(spec.draws)}); "
            "give --seed and --samples for a set of your own"
        )
    if written is not None:
        seed = written.seed if seed is None else seed
        samples = written.samples if samples is None else samples
    return name, DrawSet(seed=seed, samples=samples)


def load_study(path: Path) -> StudySpec:
    """Read and validate a study file; ScenarioError with one line naming the file, field and value."""
    raw = load_yaml_file(path)
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: expected a mapping at the top level, got {type(raw).__name__}")
    try:
        return StudySpec.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(one_line(path, err, StudySpec)) from None


def with_grid(path: Path, spec: StudySpec, axes: tuple[str, ...]) -> StudySpec:
    """The study with grid axes from the command line (`field=v1,v2,...`, each value read as YAML) added to its
    own, replacing an axis of the same field; ScenarioError with one line for a malformed or invalid axis."""
    grid = dict(spec.grid)
    for key, values in map(grid_axis, axes):
        grid[key] = [yaml.safe_load(value) for value in values]
    try:
        return StudySpec.model_validate(spec.model_dump() | {"grid": grid})
    except ValidationError as err:
        raise ScenarioError(one_line(path, err, StudySpec)) from None


def base_scenario_path(path: Path, spec: StudySpec) -> Path:
    return (path.parent / spec.scenario).resolve()
