"""Where PyBullet has no wheels (Python > 3.11) harmony runs on MuJoCo alone: with PyBullet made unimportable (an
import hook in a sitecustomize, on any Python), `harmony run` does a short scenario in MuJoCo, the engine it
defaults to there, and a scenario asking for PyBullet is refused in one line (exit 2)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from conftest import ROOT, SMOKE, assert_rejected, needs_pybullet

from harmony_cli.scenario.models import SimSpec

HIDE_PYBULLET = """
import sys


class HidePybullet:  # what a Python without PyBullet's wheels sees
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("pybullet", "pybullet_utils"):
            raise ModuleNotFoundError(f"No module named {name!r} (hidden by tests/test_mujoco_alone.py)", name=name)
        return None


sys.meta_path.insert(0, HidePybullet())
"""
HARMONY = "import sys; from harmony_cli.cli import main; sys.argv[0] = 'harmony'; main()"


def _python(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """`python ARGS` in a Python that cannot import PyBullet."""
    hook = tmp_path / "hook"
    hook.mkdir(exist_ok=True)
    (hook / "sitecustomize.py").write_text(HIDE_PYBULLET)
    env = os.environ | {"PYTHONPATH": f"{hook}{os.pathsep}{ROOT}"}
    return subprocess.run([sys.executable, *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)


def _harmony(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    return _python(tmp_path, "-c", HARMONY, *args)


def test_without_pybullet_the_cli_runs_a_short_scenario_on_mujoco(tmp_path):
    hidden = _python(tmp_path, "-c", "import pybullet")
    assert hidden.returncode != 0 and "hidden by tests/test_mujoco_alone.py" in hidden.stderr  # the hook holds
    out = tmp_path / "run"
    result = _harmony(tmp_path, "run", str(SMOKE), "--out", str(out), "--quiet")
    assert result.returncode == 0, result.stdout + result.stderr
    resolved = yaml.safe_load((out / "scenario.resolved.yaml").read_text())
    assert resolved["sim"]["engine"] == "mujoco"  # the default where PyBullet is missing, recorded
    assert "mujoco:" in (out / "run.log").read_text()


def test_without_pybullet_a_scenario_asking_for_it_is_refused_in_one_line(tmp_path):
    result = _harmony(tmp_path, "run", str(SMOKE), "--set", "sim.engine=pybullet", "--out", str(tmp_path / "run"))
    assert result.returncode == 2 and not (tmp_path / "run").exists(), result.stdout + result.stderr
    lines = (result.stdout + result.stderr).strip().splitlines()
    assert len(lines) == 1, lines
    for piece in (str(SMOKE), "sim.engine", "'pybullet'", "choose one of: mujoco"):
        assert piece in lines[0], lines[0]


@needs_pybullet
def test_a_mujoco_run_never_loads_pybullet_where_both_are_installed(tmp_path):
    out = tmp_path / "run"
    args = ["harmony", "run", str(SMOKE), "--set", "sim.engine=mujoco", "--out", str(out), "--quiet"]
    check = (
        f"import sys; from harmony_cli.cli import main\nsys.argv = {args!r}\n"
        "try:\n    main()\nexcept SystemExit as end:\n    assert not end.code, end.code\n"
        "print('loaded' if 'pybullet' in sys.modules else 'not loaded')"
    )
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    result = subprocess.run(
        [sys.executable, "-c", check], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0 and result.stdout.strip().endswith("not loaded"), result.stdout + result.stderr
    assert "mujoco:" in (out / "run.log").read_text()


def test_the_default_engine_is_pybullet_where_it_is_installed_and_mujoco_where_not(monkeypatch):
    monkeypatch.setattr("harmony_cli.scenario.models.installed_engines", lambda: ["pybullet", "mujoco"])
    assert SimSpec().engine == "pybullet"
    monkeypatch.setattr("harmony_cli.scenario.models.installed_engines", lambda: ["mujoco"])
    assert SimSpec().engine == "mujoco"
    assert SimSpec(engine="pybullet").engine == "pybullet"  # what a run's record says is read as it is


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_an_engine_this_python_lacks_is_refused_naming_file_field_value_and_choices(tmp_path, monkeypatch, engine):
    other = "mujoco" if engine == "pybullet" else "pybullet"
    monkeypatch.setattr("harmony_cli.scenario.checks.installed_engines", lambda: [other])
    path = tmp_path / "scenario.yaml"
    path.write_text(SMOKE.read_text().replace("sim:\n", f"sim:\n  engine: {engine}\n", 1))
    assert_rejected(path, ["sim.engine", repr(engine), f"choose one of: {other}"])
