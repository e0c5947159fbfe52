"""Scenario files: pydantic models (unknown keys rejected), loading with `--set` overrides, one-line errors and
cross-checks. Everything a run uses is validated here; inside harmony there are no dicts and no re-checks."""

from harmony_cli.scenario.checks import robot_of, robot_warnings
from harmony_cli.scenario.errors import ScenarioError
from harmony_cli.scenario.loading import apply_overrides, grid_axis, load_scenario, scenario_yaml
from harmony_cli.scenario.models import (
    AdmittanceSpec,
    MpcSpec,
    PlannerSpec,
    PlannerWeights,
    Scenario,
    SimSpec,
    SolverSpec,
    Weights,
)
from harmony_cli.scenario.robot import RobotSpec
from harmony_cli.scenario.task import HoldReference, PhaseSpec, Reference, RelativeTarget, SCurveReference, TaskSpec
from harmony_cli.scenario.world import BoxSpec, MotionSpec, ObstacleSpec, PushSpec, TableSpec, WorldSpec

__all__ = [
    "AdmittanceSpec",
    "BoxSpec",
    "HoldReference",
    "MotionSpec",
    "MpcSpec",
    "ObstacleSpec",
    "PhaseSpec",
    "PlannerSpec",
    "PlannerWeights",
    "PushSpec",
    "Reference",
    "RelativeTarget",
    "RobotSpec",
    "SCurveReference",
    "Scenario",
    "ScenarioError",
    "SimSpec",
    "SolverSpec",
    "TableSpec",
    "TaskSpec",
    "WorldSpec",
    "Weights",
    "apply_overrides",
    "grid_axis",
    "load_scenario",
    "robot_of",
    "robot_warnings",
    "scenario_yaml",
]
