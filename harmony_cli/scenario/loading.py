"""Reading a scenario file: YAML, `--set` overrides, validation, cross-checks; and writing it back resolved."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from pathlib import Path

import yaml
from pydantic import ValidationError

from harmony_cli.scenario.checks import (
    check_engine,
    check_pushes,
    check_robot,
    check_robot_builds,
    check_solver,
    check_task,
    urdf_file,
)
from harmony_cli.scenario.errors import ScenarioError, one_line
from harmony_cli.scenario.models import Scenario
from harmony_cli.scenario.schema import as_current
from harmony_cli.scenario.source import load_yaml_file, parse_yaml


def grid_axis(axis: str) -> tuple[str, list[str]]:
    """A `--grid` axis: 'a.b=1,2' -> ('a.b', ['1', '2']) (each value parsed as YAML where it is applied);
    ScenarioError with one line for anything else."""
    key, sep, values = axis.partition("=")
    if not sep or not key or not values:
        raise ScenarioError(f"--grid {axis!r}: expected key.path=v1,v2,..., e.g. mpc.knots=6,26")
    return key, values.split(",")


def apply_overrides(raw: dict, overrides: list[str]) -> dict:
    """Apply `a.b.c=value` overrides (value parsed as YAML) to a raw scenario mapping; in a list, a number is an
    index and a name picks the item of that name (`world.obstacles.0.motion=null`,
    `world.obstacles.cylinder.position.1=2.0`)."""
    raw = copy.deepcopy(raw)
    for item in overrides:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ScenarioError(f"--set {item!r}: expected key.path=value, e.g. mpc.knots=26")
        node = raw
        *parents, leaf = key.split(".")
        for part in parents:
            if isinstance(node, list):
                node = node[list_index(node, part, f"--set {item!r}")]
            else:
                node = node.setdefault(part, {})
            if not isinstance(node, (dict, list)):
                raise ScenarioError(f"--set {item!r}: {part!r} is not a section or a list")
        if isinstance(node, list):
            leaf = list_index(node, leaf, f"--set {item!r}")
        node[leaf] = parse_yaml(text, f"--set {item!r}", key)
    return raw


def list_index(items: list, part: str, where: str) -> int:
    """The index `part` names in a list: a number, or the name of one of its items (obstacles, tables, ...)."""
    if part.isdigit() and int(part) < len(items):
        return int(part)
    names = [i.get("name") for i in items if isinstance(i, dict)]
    if part in names:
        return names.index(part)
    named = f" or a name ({', '.join(map(str, names))})" if any(names) else ""
    raise ScenarioError(f"{where}: {part!r} is not an index of a list of {len(items)}{named}")


def load_scenario(
    path: str | Path, overrides: Sequence[str] = (), notices: list[str] | None = None, runnable: bool = True
) -> Scenario:
    """Read (a file of an older schema as the current one: its deprecation notice appended to `notices`), override
    and validate a scenario; raise ScenarioError with a one-line message. `runnable=False` reads a run's record
    (scenario.resolved.yaml) without asking for its physics engine here."""
    path = Path(path)
    raw = load_yaml_file(path)
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: expected a mapping at the top level, got {type(raw).__name__}")
    raw = as_current(raw, path, notices)
    try:
        raw = apply_overrides(raw, list(overrides))
    except ScenarioError as err:
        raise ScenarioError(f"{path}: {err}") from None
    robot = raw.get("robot")
    if isinstance(robot, dict) and isinstance(robot.get("urdf"), str):  # a missing URDF first, as such
        urdf_file(path, robot["urdf"])
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as err:
        raise ScenarioError(one_line(path, err)) from None
    check_robot(path, scenario)
    check_task(path, scenario)
    check_pushes(path, scenario)
    if runnable:
        check_engine(path, scenario)
    check_solver(path, scenario)
    check_robot_builds(path, scenario)
    return scenario


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as YAML, every field given (`schema: 2` first): what a run directory keeps."""
    return yaml.safe_dump(scenario.model_dump(mode="json"), sort_keys=False)
