"""The package as a user installs it: a wheel built by `python -m build` from this checkout, installed into a fresh
virtual environment outside the repository, copies out the scenarios it ships and runs one of them to success."""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from typer.testing import CliRunner

import harmony_cli
from harmony_cli.cli import app

ROOT = Path(__file__).resolve().parents[1]
NOT_BUILT_FROM = shutil.ignore_patterns(".git", ".venv*", "results", "build", "dist", "*.egg-info", "__pycache__")


def test_harmony_examples_copies_the_repositorys_scenarios_and_studies_byte_for_byte(tmp_path):
    result = CliRunner().invoke(app, ["examples", str(tmp_path / "ex")])
    assert result.exit_code == 0, result.output
    for folder in ("scenarios", "studies"):
        shipped = sorted(p.relative_to(ROOT / folder) for p in (ROOT / folder).rglob("*.yaml"))
        copied = sorted(p.relative_to(tmp_path / "ex" / folder) for p in (tmp_path / "ex" / folder).rglob("*.yaml"))
        assert copied == shipped and shipped
        assert all((ROOT / folder / p).read_bytes() == (tmp_path / "ex" / folder / p).read_bytes() for p in shipped)


def test_harmony_examples_refuses_a_folder_that_holds_something_in_one_line(tmp_path):
    (tmp_path / "mine.yaml").write_text("name: mine\n")
    result = CliRunner().invoke(app, ["examples", str(tmp_path)])
    assert result.exit_code == 2
    assert str(tmp_path) in result.output and len(result.output.strip().splitlines()) == 1
    assert (tmp_path / "mine.yaml").read_text() == "name: mine\n"


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel `python -m build` makes from a copy of this checkout (the build writes beside its sources)."""
    source, out = tmp_path_factory.mktemp("source") / "harmony", tmp_path_factory.mktemp("dist")
    shutil.copytree(ROOT, source, symlinks=True, ignore=NOT_BUILT_FROM)
    build = [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out), str(source)]
    subprocess.run(build, cwd=out, check=True, capture_output=True, text=True)  # not beside a build/ folder
    (built,) = out.glob("harmony_cli-*.whl")
    return built


def test_the_wheel_installed_outside_the_repository_runs_a_scenario_it_ships_to_success(wheel, tmp_path):
    venv, env = tmp_path / "venv", {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=env)
    python = venv / "bin" / "python"
    install = [python, "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)]
    subprocess.run(install, check=True, env=env, cwd=tmp_path)
    # then harmony's dependencies from this environment (a path entry: its .pth files, which make this checkout
    # importable, are not read); harmony itself comes from the wheel, installed before them
    purelib = "import sysconfig; print(sysconfig.get_path('purelib'))"
    site = Path(subprocess.check_output([python, "-c", purelib], env=env, text=True).strip())
    (site / "dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    which = [python, "-c", "import harmony_cli; print(harmony_cli.__file__)"]
    where = subprocess.check_output(which, cwd=tmp_path, env=env, text=True)
    assert Path(where.strip()).is_relative_to(venv)
    harmony = venv / "bin" / "harmony"
    version = subprocess.check_output([harmony, "--version"], cwd=tmp_path, env=env, text=True).strip()
    assert version == f"harmony {harmony_cli.__version__}"
    subprocess.run([harmony, "examples", "ex"], cwd=tmp_path, env=env, check=True, capture_output=True)
    scene = "ex/scenarios/smoke/box_lift.yaml"  # MuJoCo: the engine every Python harmony supports has
    run = [harmony, "run", scene, "--set", "sim.engine=mujoco", "--out", "run", "--quiet"]
    done = subprocess.run(run, cwd=tmp_path, env=env, capture_output=True, text=True)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["task"]["success"], done.stderr
    assert done.returncode == 0, done.stderr
