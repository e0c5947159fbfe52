"""harmony run / compare end to end on the smoke scenario: real MPC, real PyBullet, real files."""

import json

import pandas as pd
from conftest import SMOKE
from typer.testing import CliRunner

from harmony_cli.cli import app

runner = CliRunner()


def test_run_writes_a_self_describing_run_directory(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", "--set", "mpc.knots=8"])
    assert result.exit_code == 0, result.output
    for name in (
        "scenario.resolved.yaml",
        "overrides.yaml",
        "meta.json",
        "steps.csv",
        "summary.json",
        "run.log",
        "solve_time.png",
        "hand_paths.png",
        "tracking_error.png",
        "loop_time.png",
    ):
        assert (out / name).exists(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["failed_solves"] == 0
    assert summary["knots"] == 8 and summary["decision_variables"] == 108
    assert summary["tracking_error"]["max_m"] < 0.02
    meta = json.loads((out / "meta.json").read_text())
    assert {"packages", "git_sha", "cpu", "seed", "concurrency"} <= set(meta)
    steps = pd.read_csv(out / "steps.csv")
    assert len(steps) == 50 and {
        "solve_ms",
        "status",
        "iterations",
        "cost_position_left",
        "left_ref_x",
        "left_meas_x",
        "cmd_qd_base_x",
        "left_force_normal_N",
        "right_force_z_N",
    } <= set(steps.columns)
    # each step's breakdown: the whole-body MPC's part of the loop is inside it, every part took time
    parts = ["sense_ms", "wbmpc_ms", "previous_log_ms", "previous_physics_ms"]
    assert (steps["wbmpc_ms"] <= steps["loop_ms"]).all() and (steps[parts].iloc[1:] > 0).all().all()
    assert (steps["qp_solves"] >= 1).all()
    assert "mpc.knots=8" in (out / "overrides.yaml").read_text()
    # the resolved scenario re-runs from the run directory alone
    again = runner.invoke(app, ["validate", str(out / "scenario.resolved.yaml")])
    assert again.exit_code == 0, again.output


def test_base_moves_by_velocity_and_hands_follow_the_reference(tmp_path):
    out = tmp_path / "run"
    runner.invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", "--set", "sim.duration=2.0"])
    steps = pd.read_csv(out / "steps.csv")
    assert steps["q_base_x"].iloc[-1] > 0.05  # the hands moved forward, the base followed
    assert (steps["left_meas_x"] - steps["left_ref_x"]).abs().max() < 0.02


def test_a_run_that_fails_part_way_leaves_its_logs_and_a_status(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(
        app,
        [
            "run",
            str(SMOKE),
            "--out",
            str(out),
            "--quiet",
            "--set",
            "solver.name=ipopt",
            "--set",
            "solver.options={ipopt.max_iter: 0}",
        ],
    )
    assert result.exit_code == 1 and "Traceback" not in result.output and "run failed" in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "solve failed" in summary["error"]
    assert "status: failed" in (out / "run.log").read_text()


def test_compare_writes_table1_layout_with_decision_variables_from_the_built_problems(tmp_path):
    out = tmp_path / "cmp"
    result = runner.invoke(
        app,
        [
            "compare",
            str(SMOKE),
            "--grid",
            "mpc.transcription=traditional,bezier",
            "--set",
            "sim.duration=0.4",
            "--out",
            str(out),
            "--name",
            "table1",
        ],
    )
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "table1.csv", index_col=0)
    counts = sorted(int(v.rsplit("= ", 1)[1]) for v in table.loc["Decision variable No."] if "=" in str(v))
    assert counts == [6 * 18, 2 * 6 * 18]  # Bezier: N x n_dof; traditional: 2 K x n_dof (K = 6 in the smoke file)
    cpu = json.loads((out / "runs" / "transcription-bezier" / "meta.json").read_text())["cpu"]
    assert cpu in (out / "table1.md").read_text() and (out / "table1.tex").exists()
    assert (out / "fig4_solve_time.png").exists() and (out / "fig4_tracking_error.png").exists()


def test_grid_points_expand_and_label_by_the_last_key_and_the_whole_value():
    from harmony_cli.experiment.sweep import expand_grid, point_label

    points = expand_grid(["mpc.knots=6,26", "admittance.off_squeeze=0.0003"])
    assert points == [
        ["mpc.knots=6", "admittance.off_squeeze=0.0003"],
        ["mpc.knots=26", "admittance.off_squeeze=0.0003"],
    ]
    assert [point_label(p) for p in points] == ["knots-6_off_squeeze-0.0003", "knots-26_off_squeeze-0.0003"]
    assert point_label([]) == "base"


def test_failed_runs_lists_every_grid_run_that_did_not_complete_with_its_reason(tmp_path):
    from harmony_cli.experiment.sweep import failed_runs

    states = {"ok": {"status": "completed"}, "cut": {"status": "interrupted", "reason": "SIGTERM received"}}
    states["bad"] = {"status": "failed", "error": "RuntimeError: x"}
    for name, summary in states.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "none").mkdir()
    dirs = [tmp_path / n for n in ("ok", "cut", "bad", "none")]
    assert failed_runs(dirs) == [
        "cut (interrupted: SIGTERM received)",
        "bad (failed: RuntimeError: x)",
        "none (no summary.json: )",
    ]
