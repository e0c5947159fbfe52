"""A run directory describes itself: the resolved scenario (re-runnable as is), the overrides that made it, and
meta.json (package versions, code version, git SHA, CPU, cores, concurrency, seed, the solver paths that ran)."""

from __future__ import annotations

import os
import platform
from datetime import datetime
from importlib import metadata
from pathlib import Path

import yaml

from harmony_cli.provenance import code_version, cpu_model, git_sha
from harmony_cli.robot.prepare import AUTO
from harmony_cli.scenario import Scenario, robot_of, scenario_yaml

OVERRIDES = "overrides.yaml"  # a run's scenario file and its --set overrides, as given
PACKAGES = ("harmony-cli", "casadi", "pyoptas", "pin", "pybullet", "mujoco", "numpy", "pydantic", "pandas")


def default_run_dir(name: str, root: Path = Path("results/runs")) -> Path:
    return root / f"{name}-{datetime.now().strftime('%Y%m%d-%H%M%S-%f')}"


def write_inputs(out: Path, path: Path, overrides: list[str], scenario: Scenario) -> None:
    """scenario.resolved.yaml (the URDF and mesh paths made absolute and `robot.mount: auto` the mount it chose:
    re-runnable from `out`, the same robot) and overrides.yaml."""
    out.mkdir(parents=True, exist_ok=True)
    resolved = yaml.safe_load(scenario_yaml(scenario))
    resolved["robot"]["urdf"] = str((path.parent / scenario.robot.urdf).resolve())
    resolved["robot"]["package_paths"] = [str((path.parent / p).resolve()) for p in scenario.robot.package_paths]
    if scenario.robot.mount == AUTO:  # the robot is built once per process: the scenario's validation built it
        mount = robot_of(scenario, path.parent).mount
        resolved["robot"]["mount"] = None if mount is None else {"xyz": mount[0], "rpy_deg": mount[1]}
    (out / "scenario.resolved.yaml").write_text(yaml.safe_dump(resolved, sort_keys=False))
    (out / OVERRIDES).write_text(yaml.safe_dump({"scenario": str(path), "overrides": list(overrides)}))


def read_inputs(out: Path) -> tuple[Path, list[str]] | None:
    """The scenario file and the `--set` overrides a run in `out` was made from (write_inputs), or None when its
    overrides.yaml is missing."""
    written = out / OVERRIDES
    if not written.is_file():
        return None
    recorded = yaml.safe_load(written.read_text())
    return Path(recorded["scenario"]), list(recorded.get("overrides", []))


def machine_meta(concurrency: int) -> dict:
    versions = {}
    for pkg in PACKAGES:
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = "absent"
    return {
        "python": platform.python_version(),
        "packages": versions,
        "code_version": code_version(),
        "git_sha": git_sha(),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "host": platform.node(),
        "concurrency": concurrency,
        "started": datetime.now().isoformat(timespec="seconds"),
    }
