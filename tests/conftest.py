import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from harmony_cli.robot.model import load_robot
from harmony_cli.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[1]
TABLE1 = ROOT / "scenarios/paper/table1_s_shape.yaml"
SMOKE = ROOT / "scenarios/smoke/s_shape_short.yaml"


@pytest.fixture(scope="session")
def eva():
    scenario = load_scenario(TABLE1)
    return load_robot(scenario.robot, TABLE1.parent)


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def assert_rejected(path: Path, pieces: list[str]) -> None:
    """Loading `path` fails with one line that starts with the file and names every piece (field, value,
    choices)."""
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)), message
    for piece in pieces:
        assert piece in message, message


def assert_exit_follows_outcome(result, run_dir: Path) -> dict:
    """`harmony run`'s exit code says what its summary.json does: 0 for a run that did what it was asked (its task,
    or its reference within tolerance), 1 for one that completed without doing it. Returns the summary."""
    from harmony_cli.experiment.results import succeeded

    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["status"] == "completed", result.output
    assert result.exit_code == (0 if succeeded(summary) else 1), result.output
    return summary


HAS_PYBULLET = importlib.util.find_spec("pybullet") is not None
# the tests of PyBullet itself (harmony's PyBullet engine, or PyBullet as the reference others are checked against)
needs_pybullet = pytest.mark.skipif(
    not HAS_PYBULLET, reason="needs PyBullet, which has no wheels for this Python (> 3.11): MuJoCo alone"
)


def swinging(robot, t: float):
    """(q, qd) of EVA's arms swinging at t: LARM_JOINT1 and RARM_JOINT3 0.4 sin(2t) rad about home, the rest at
    home (wrist-sensing tests: the tools' m a, hands up to ~0.15 m/s)."""
    q, qd = robot.home.copy(), np.zeros(robot.n_dof)
    for joint in ("LARM_JOINT1", "RARM_JOINT3"):
        q[robot.index(joint)] += 0.4 * np.sin(2 * t)
        qd[robot.index(joint)] = 0.8 * np.cos(2 * t)
    return q, qd
