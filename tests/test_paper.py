"""The Table 1 scenario end to end (slow: `make test-slow`): every configuration closes the loop in PyBullet."""

import json

import pytest
from conftest import TABLE1

from harmony_cli.experiment.run import run_scenario


@pytest.mark.slow
@pytest.mark.parametrize(
    "transcription, knots", [("traditional", 6), ("traditional", 26), ("bezier", 6), ("bezier", 26)]
)
def test_table1_configuration_runs_the_whole_s_without_a_failed_solve(tmp_path, transcription, knots):
    out = run_scenario(
        TABLE1, [f"mpc.transcription={transcription}", f"mpc.knots={knots}"], tmp_path / "run", progress=False
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["failed_solves"] == 0
    assert summary["steps"] == round(27.0 / 0.02)
    if (transcription, knots) == ("bezier", 26):
        assert summary["tracking_error"]["max_m"] <= 0.054  # the paper's 5.4 cm
