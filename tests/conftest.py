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
