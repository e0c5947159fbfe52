"""The package's layout rules hold: controllers load without the simulator, and the import contracts catch a
violation."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import HAS_PYBULLET, ROOT

ENGINES = ("pybullet", "pybullet_utils", "mujoco")
LOADED = "import sys, {modules}; print(sorted({{m.split('.')[0] for m in sys.modules}} & set(" + repr(ENGINES) + ")))"


def _engine_modules_after_importing(*modules: str) -> str:
    code = LOADED.format(modules=", ".join(modules))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()


def test_the_whole_body_mpc_and_the_planner_load_without_a_physics_engine():
    assert (
        _engine_modules_after_importing(
            "harmony_cli.mpc.wholebody", "harmony_cli.planning.hand_mpc", "harmony_cli.planning.planner"
        )
        == "[]"
    )
    # the check sees each engine when it is loaded
    if HAS_PYBULLET:
        assert _engine_modules_after_importing("harmony_cli.sim.bullet") == "['pybullet', 'pybullet_utils']"
    assert _engine_modules_after_importing("mujoco") == "['mujoco']"


@pytest.mark.skipif(
    shutil.which("lint-imports", path=str(Path(sys.executable).parent)) is None,
    reason="import-linter is in the dev extra (make install)",
)
def test_the_import_contracts_reject_pybullet_in_the_mpc_package(tmp_path):
    shutil.copytree(ROOT / "harmony_cli", tmp_path / "harmony_cli", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    lint = [str(Path(sys.executable).parent / "lint-imports"), "--no-cache"]
    env = {"PYTHONPATH": str(tmp_path), "PATH": str(Path(sys.executable).parent)}
    assert subprocess.run(lint, cwd=tmp_path, env=env, capture_output=True).returncode == 0
    problem = tmp_path / "harmony_cli/mpc/problem.py"
    problem.write_text(problem.read_text() + "\nimport pybullet  # noqa: E402, F401\n")
    broken = subprocess.run(lint, cwd=tmp_path, env=env, capture_output=True, text=True)
    assert broken.returncode != 0
    assert "harmony_cli.mpc.problem -> pybullet" in broken.stdout, broken.stdout
