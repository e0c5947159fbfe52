"""`harmony bench`'s closed-loop part times a real run from its steps and compares with this machine's last bench."""

import io
import json

from conftest import SMOKE, needs_pybullet
from rich.console import Console
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.experiment.loop_bench import run_loop_bench


def test_loop_bench_reports_tails_and_real_time_factor_and_shows_the_last_bench_beside(tmp_path):
    """Every part of a step gets median <= p99 <= max (the replay log's also as % of the loop median); the real-time
    factor is simulated over wall time; a second bench on this machine prints the first one's numbers beside its
    own."""
    out = tmp_path / "loop.json"
    first = run_loop_bench([SMOKE], out, Console(file=io.StringIO()))["experiments"][0]
    assert {"loop (planner + whole-body MPC)", "sensing", "whole-body MPC", "logging", "replay log", "physics"} <= set(
        first["parts_ms"]
    )
    cost = first["replay_log_pct_of_loop_median"]  # replay.npz's logging, as % of the loop median
    assert 0 < cost["median"] <= cost["p95"] <= cost["max"]
    for stats in first["parts_ms"].values():
        assert 0 < stats["median"] <= stats["p99"] <= stats["p99.9"] <= stats["max"]
    simulated = first["steps"] * 0.02  # the smoke scenario's control period
    assert abs(first["real_time_factor"] * first["wall_s"] - simulated) < 1e-6 * simulated
    assert json.loads(out.read_text())["experiments"][0]["name"] == first["name"]
    printed = io.StringIO()
    run_loop_bench([SMOKE], out, Console(file=printed, width=200))
    assert "last bench" in printed.getvalue() and "replay log (replay.npz) per step" in printed.getvalue()


@needs_pybullet
def test_loop_bench_runs_each_experiment_in_each_engine_it_is_given():
    experiments = run_loop_bench([SMOKE], None, Console(file=io.StringIO()), ["mujoco", "pybullet"])["experiments"]
    assert [e["engine"] for e in experiments] == ["mujoco", "pybullet"]
    assert experiments[0]["name"].endswith("[mujoco]") and experiments[0]["steps"] == experiments[1]["steps"]
    for e in experiments:
        assert 0 < e["physics_pct_of_loop_wall"] < 100 and e["loop_wall_s"] < e["wall_s"]


def test_bench_with_an_empty_loop_option_times_the_solvers_alone(tmp_path):
    out = tmp_path / "bench.json"
    args = ["bench", "--solver", "rti", "--knots", "6", "--steps", "3", "--loop", "", "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    configs = [(r["transcription"], r["knots"]) for r in json.loads(out.read_text())["results"]]
    assert configs == [("traditional", 6), ("bezier", 6)]
    assert not (tmp_path / "loop.json").exists()
