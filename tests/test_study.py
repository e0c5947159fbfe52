"""Studies: samples reproducible whatever their number, impossible scenes drawn again and counted, one Parquet row
per run carrying its summary's scalars, resume, and Ray giving the process pool's rows. The runs are the smoke box
lift cut to 0.4 s (studies/smoke_box_lift.yaml)."""

from __future__ import annotations

import json
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.experiment.run import run_scenario
from harmony_cli.maths.shapes import obstacle_shape, table_shape
from harmony_cli.planning.stance import StanceClass
from harmony_cli.planning.stance_check import written_stance_class
from harmony_cli.scenario import ScenarioError, load_scenario
from harmony_cli.study.intervals import wilson
from harmony_cli.study.plan import plan_runs
from harmony_cli.study.report import refusal_kind, write_report
from harmony_cli.study.run_again import run_again
from harmony_cli.study.runner import Options, plan_study, run_study
from harmony_cli.study.sampling import Sampler
from harmony_cli.study.scene_kind import COLUMN as SCENE_KIND
from harmony_cli.study.scene_kind import describer
from harmony_cli.study.spec import base_scenario_path, draw_set, load_study
from harmony_cli.study.table import TABLE, flatten, outcome, run_reason
from harmony_cli.tasks.scene_check import SceneCheck, planar_gap

STUDY = ROOT / "studies" / "smoke_box_lift.yaml"
TIMING = ("_ms", "time_s", "wall_clock", "run_dir")  # columns that differ between two runs of one scene


def _sampler(path: Path = STUDY) -> tuple:
    spec = load_study(path)
    scenario = base_scenario_path(path, spec)
    name, draws = draw_set(spec, None, None, None)
    return spec, Sampler(spec, scenario, SceneCheck(scenario.parent, spec.check.clearance), (name, draws.seed))


def test_sample_i_is_the_same_scene_whether_the_study_has_5_or_50_samples():
    spec, sampler = _sampler()
    five, fifty = plan_runs(spec, sampler, 5), plan_runs(spec, sampler, 50)
    assert [r.overrides for r in five] == [r.overrides for r in fifty[:5]]
    assert [r.key for r in five] == [r.key for r in fifty[:5]]
    assert len({r.key for r in fifty}) == 50  # and the scenes differ


def test_a_draw_with_an_obstacle_on_the_table_is_refused_drawn_again_and_counted(tmp_path):
    # a post anywhere in a strip half of which lies under the table top (x 1.2-2.0 at this table's yaw)
    path = tmp_path / "study.yaml"
    path.write_text(
        f"name: posts\nscenario: {ROOT / 'scenarios/smoke/box_lift.yaml'}\nsamples: 12\nseed: 3\n"
        'set: ["sim.duration=0.4", "world.obstacles=[{name: post, shape: cylinder, position: [1.0, 1.5, 0.5], '
        'size: [0.2, 0.2, 1.0]}]"]\n'
        "vary:\n  world.obstacles.post.position: {uniform: [[0.6, 0.5, 0.5], [2.4, 0.9, 0.5]]}\n"
    )
    spec, sampler = _sampler(path)
    samples = [sampler.sample(i) for i in range(12)]
    refused = [why for s in samples for why in s.rejected]
    assert refused and all("obstacle post overlaps table table" in why for why in refused), refused
    assert {refusal_kind(why) for why in refused} == {"an obstacle overlapping a table or the box"}  # the report's
    for s in samples:  # what was kept is clear of the table
        scenario = sampler.scenario(s.overrides)
        assert sampler.check(scenario) is None
        assert planar_gap(obstacle_shape(scenario.world.obstacles[0]), table_shape(scenario.world.tables[0])) >= 0
    again = _sampler(path)[1]
    assert [len(again.sample(i).rejected) for i in range(12)] == [len(s.rejected) for s in samples]


def test_the_table_has_one_row_per_run_with_every_scalar_of_its_summary_and_resume_runs_nothing(tmp_path):
    out = tmp_path / "study"
    first = run_study(STUDY, Options(out=out, samples=3, progress=False, plots="none"))
    table = pd.read_parquet(out / TABLE)
    assert (first.ran, first.skipped, len(table)) == (3, 0, 3) and list(table["sample"]) == [0, 1, 2]
    assert load_scenario(out / "base_scenario.yaml").sim.duration == 0.4  # the base scene with the study's set:
    for row in table.to_dict("records"):
        summary = json.loads((Path(row["run_dir"]) / "summary.json").read_text())
        scalars = {
            k: v for k, v in flatten(summary, "summary").items() if k not in ("summary.status", "summary.reason")
        }
        assert scalars and all(_same(row[k], v) for k, v in scalars.items()), row["run_dir"]
        assert row["status"] == summary["status"] == "completed" and row["outcome"] in ("success", "phase timeout")
    replayed = run_scenario(
        Path(table["run_dir"][1]) / "scenario.resolved.yaml", [], tmp_path / "replay", progress=False
    )
    original, again = (pd.read_csv(d / "steps.csv") for d in (Path(table["run_dir"][1]), replayed))
    same = [c for c in original.columns if not any(t in c for t in TIMING)]
    pd.testing.assert_frame_equal(original[same], again[same])  # the run directory replays its run exactly
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("runs/*/summary.json")}
    second = run_study(STUDY, Options(out=out, samples=3, progress=False, plots="none"))
    assert (second.ran, second.skipped) == (0, 3)
    assert {p: p.stat().st_mtime_ns for p in out.glob("runs/*/summary.json")} == stamps
    assert (out / "report.md") in write_report(out) and "| base | 3 |" in (out / "report.md").read_text()


@pytest.mark.slow  # 21 s (starts a local Ray)
def test_a_local_ray_instance_gives_the_rows_of_the_process_pool(tmp_path):
    ray = pytest.importorskip("ray")
    pool = run_study(STUDY, Options(out=tmp_path / "pool", samples=4, jobs=2, progress=False, plots="none"))
    try:
        ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
        on_ray = run_study(STUDY, Options(out=tmp_path / "ray", samples=4, ray="auto", progress=False, plots="none"))
    finally:
        ray.shutdown()
    assert not ray.is_initialized()
    columns = [c for c in pool.table.columns if not any(t in c for t in TIMING)]
    assert set(columns) <= set(on_ray.table.columns) and len(columns) > 50
    left = pool.table.sort_values("sample")[columns].reset_index(drop=True)
    right = on_ray.table.sort_values("sample")[columns].reset_index(drop=True)
    pd.testing.assert_frame_equal(left, right)


def test_the_wilson_interval_matches_its_closed_form_at_known_points():
    assert wilson(0, 10) == pytest.approx((0.0, 0.27753), abs=1e-5)  # z^2 / (n + z^2)
    low, high = wilson(8, 10)
    assert (low, high) == pytest.approx((0.49016, 0.94332), abs=1e-5)
    assert np.isnan(wilson(0, 0)[0])


def _same(a, b) -> bool:
    if isinstance(b, float) and np.isnan(b):
        return a is None or np.isnan(a)
    return a == b or (isinstance(b, float) and a == pytest.approx(b, rel=1e-12))


BAD_STUDIES = [  # (what the study file gets, pieces of the one line that refuses it)
    ("samples: 4", "samples: 0", ["samples: 0", "greater than 0"]),
    ("seed: 7", "seed: 7\nsamplez: 3", ["samplez", "unknown key", "valid keys"]),
    ("world.box.mass: {uniform: [0.5, 1.5]}", "world.box.mass: {uniform: [1.5, 0.5]}", ["low 1.5 is above high 0.5"]),
    ("world.box.mass: {uniform: [0.5, 1.5]}", "world.box.mas: {uniform: [0.5, 1.5]}", ["vary", "world.box.mas"]),
    ("world.box.mass: {uniform: [0.5, 1.5]}", "world.box.mass: {choice: [1], relative: true}", ["relative"]),
    (
        "world.box.mass: {uniform: [0.5, 1.5]}",
        "world.box.mass: {uniform: [0.5, 1.5], normal: [1, 0.1]}",
        ["exactly one"],
    ),
    ("world.box.mass: {uniform: [0.5, 1.5]}", "world.box.mass: {uniform: [-2.0, -1.0]}", ["no possible scene", "mass"]),
    ("../scenarios/smoke/box_lift.yaml", "../scenarios/smoke/nope.yaml", ["nope.yaml", "file not found"]),
]


@pytest.mark.parametrize(("old", "new", "pieces"), BAD_STUDIES)
def test_a_bad_study_file_gets_one_line_and_exit_code_2(tmp_path, old, new, pieces):
    text = STUDY.read_text()
    assert old in text
    path = tmp_path / "study.yaml"
    path.write_text(text.replace(old, new).replace("../scenarios", str(ROOT / "scenarios")))
    result = CliRunner().invoke(app, ["study", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "Traceback" not in result.output, result.output
    assert all(piece in lines[0] for piece in pieces), lines[0]
    assert not (tmp_path / "out" / "runs").exists()  # nothing ran


def test_sigterm_to_a_study_ends_its_runs_cleanly_keeps_the_table_and_a_rerun_is_asked_for(tmp_path):
    path = tmp_path / "study.yaml"
    long = STUDY.read_text().replace('"sim.duration=0.4"', '"sim.duration=3600"').replace("samples: 4", "samples: 2")
    path.write_text(long.replace("../scenarios", str(ROOT / "scenarios")))
    out = tmp_path / "out"
    harmony = Path(sys.executable).with_name("harmony")
    command = [str(harmony), "study", str(path), "--out", str(out), "--jobs", "2", "--quiet", "--plots", "none"]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while len([p for p in out.glob("runs/**/steps.jsonl") if p.stat().st_size]) < 2:
        assert proc.poll() is None and time.time() < deadline, (proc.kill(), proc.communicate())
        time.sleep(0.1)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=90)
    assert proc.returncode == 143 and stderr.strip().splitlines()[-1].startswith("interrupted: SIGTERM"), stderr
    table = pd.read_parquet(out / TABLE)
    assert list(table["status"]) == ["interrupted"] * 2 and list(table["outcome"]) == ["interrupted"] * 2
    assert table["success"].isna().all()  # no result: not counted as a failure
    again = plan_study(path, Options(out=out, progress=False))  # started again: nothing to run unasked
    assert len(again.runs) == 2 and again.todo == []
    assert len(plan_study(path, Options(out=out, progress=False, rerun=("interrupted",))).todo) == 2


def test_the_report_gives_each_run_that_did_not_succeed_a_command_that_runs_it_again(tmp_path):
    """report.md lists every run that did not succeed with a `harmony run` command, and no other: from its
    overrides where the run directory has them, else its resolved scenario."""
    table = pd.DataFrame(
        {
            "point": ["base"] * 3,
            "sample": [0, 1, 2],
            "success": [True, False, None],
            "outcome": ["success", "dropped", "interrupted"],
            "reason": ["", "the box fell", "SIGTERM"],
            "resamples": [0, 0, 0],
            "run_dir": [str(tmp_path / f"runs/s{i}") for i in range(3)],
        }
    )
    table.to_parquet(tmp_path / TABLE)
    (tmp_path / "runs/s1").mkdir(parents=True)
    drawn = {"scenario": str(tmp_path / "base.yaml"), "overrides": ["world.box.mass=1.2"]}
    (tmp_path / "runs/s1/overrides.yaml").write_text(json.dumps(drawn))
    write_report(tmp_path)
    report = (tmp_path / "report.md").read_text()
    assert f"`harmony run {tmp_path / 'base.yaml'} --set world.box.mass=1.2 --out {tmp_path / 'runs/s1'}`" in report
    assert f"`harmony run {tmp_path / 'runs/s2/scenario.resolved.yaml'}`" in report
    assert str(tmp_path / "runs/s0") not in report


def test_the_reports_command_runs_a_draw_again_step_for_step_into_its_run_directory(tmp_path):
    first = run_study(STUDY, Options(out=tmp_path / "study", samples=1, progress=False, plots="none"))
    assert first.ran == 1
    run_dir = Path(pd.read_parquet(tmp_path / "study" / TABLE)["run_dir"][0])
    words = shlex.split(run_again(run_dir))
    assert words[:2] == ["harmony", "run"] and words[-2:] == ["--out", str(run_dir)]
    again = tmp_path / "again"
    result = CliRunner().invoke(app, [*words[1:-1], str(again), "--quiet"])
    assert result.exit_code in (0, 1), result.output  # the smoke study's 0.4 s runs end before their phases do
    original, repeated = (pd.read_csv(d / "steps.csv") for d in (run_dir, again))
    same = [c for c in original.columns if not any(t in c for t in TIMING)]
    pd.testing.assert_frame_equal(original[same], repeated[same])


def test_a_run_stopped_after_its_box_fell_counts_as_dropped_and_says_both():
    """The planner failing for a second once the box is on the floor stops the run: the drop, earlier, is the cause."""
    failure = {"category": "dropped", "reason": "the box fell off the tables at t = 47.92 s (carry)", "at_s": 47.92}
    stopped = {"status": "failed", "failure": "solver", "reason": "the planner failed every solve from t = 53.96 s"}
    summary = stopped | {"task": {"success": False, "failure": failure}}
    assert outcome(summary) == "dropped"
    assert run_reason(summary) == (
        "the box fell off the tables at t = 47.92 s (carry); then the run stopped: the planner failed every solve "
        "from t = 53.96 s"
    )
    at_end = summary | {"task": {"success": False, "failure": failure | {"category": "box off goal", "at_s": None}}}
    assert outcome(at_end) == "run failed: solver"  # judged at the end: the stop may be why


REASONS = {"impossible": "phase carry: no passage for the base from its start", "dropped": "the box fell"}


def _report_of(tmp_path: Path, outcomes: list[str], rejected: list[list[str]], more: dict | None = None) -> str:
    """report.md of a table of one grid point with these outcomes, per sample its refused draws, and `more`
    columns."""
    table = pd.DataFrame(
        {
            "point": ["base"] * len(outcomes),
            "sample": list(range(len(outcomes))),
            "success": [o.startswith("success") if o != "interrupted" else None for o in outcomes],
            "outcome": outcomes,
            "reason": [REASONS.get(o, "") for o in outcomes],
            "resamples": [len(r) for r in rejected],
            "rejected": [json.dumps(r) for r in rejected],
            "run_dir": [str(tmp_path / f"runs/s{i}") for i in range(len(outcomes))],
        }
        | (more or {})
    )
    table.to_parquet(tmp_path / TABLE)
    write_report(tmp_path)
    return (tmp_path / "report.md").read_text()


def test_the_report_breaks_the_outcomes_down_by_the_written_stance_with_each_kind_s_own_interval(tmp_path):
    outcomes = ["success", "dropped", "success, a phase late", "no stance", "impossible", "success"]
    kinds = [StanceClass.CLEAR, StanceClass.CLEAR, StanceClass.TURN_CLEARS] + [StanceClass.NO_TURN_CLEARS] * 3
    report = _report_of(tmp_path, outcomes, [[]] * len(outcomes), {SCENE_KIND: [k.value for k in kinds]})
    # per kind: the draws run (a draw refused as impossible is not one), successes, rate, Wilson, the failures
    assert "| clear | base | 2 | 1 | 50 % | 9 % - 91 % | 1 dropped |" in report, report
    assert "| blocked, a turn clears it | base | 1 | 1 | 100 % | 21 % - 100 % | - |" in report
    assert "| blocked, no turn clears it | base | 2 | 1 | 50 % | 9 % - 91 % | 1 no stance |" in report


def test_each_drawn_scene_of_a_study_with_a_box_and_a_task_has_its_written_stance_class(tmp_path):
    spec, sampler = _sampler()
    plain = plan_runs(spec, sampler, 3)
    assert all(run.scene == {} for run in plain)  # the sampler of the tests above describes nothing
    described = Sampler(spec, sampler.path, sampler.check, (sampler.draws, sampler.seed), describer(sampler.check))
    runs = plan_runs(spec, described, 3)
    assert [run.overrides for run in runs] == [run.overrides for run in plain]  # the same scenes
    for run in runs:
        scenario = sampler.scenario(run.overrides)
        expected = written_stance_class(scenario, sampler.check.robot(scenario))
        assert run.scene == {"written_stance": expected.value}


def test_the_report_counts_the_draws_refused_as_impossible_by_kind(tmp_path):
    overlap = "obstacle cylinder overlaps table pick_table (overlapping by 3.3 cm)"
    start = "obstacle cylinder overlaps the robot's start (overlapping by 1.0 cm)"
    report = _report_of(tmp_path, ["success"] * 3, [[overlap, start], [], [overlap]])
    assert (
        "3 successes of 3 draws (100 %, Wilson 95 % 44 % - 100 %); 3 refused as impossible (2 an obstacle "
        "overlapping a table or the box, 1 an obstacle overlapping the robot's start)." in report
    ), report


def test_the_report_s_denominator_counts_a_no_stance_draw_and_not_a_refused_or_unfinished_one(tmp_path):
    outcomes = ["success", "no stance", "success, a phase late", "impossible", "interrupted", "dropped"]
    report = _report_of(tmp_path, outcomes, [[]] * len(outcomes))
    assert (  # success, no stance, the late success and the drop are draws; the late success is a success
        "2 successes of 4 draws (50 %, Wilson 95 % 15 % - 85 %); 1 refused as impossible (1 no passage for the "
        "base); 1 of the successes had a phase that ended late (it waited for its goal); 1 of its 6 runs without a "
        "result (interrupted or not run), not counted." in report
    ), report


def test_the_report_s_table_says_per_grid_point_what_was_planned_run_succeeded_failed_refused_and_not_run(tmp_path):
    outcomes = ["success", "no stance", "success, a phase late", "impossible", "interrupted", "dropped"]
    report = _report_of(tmp_path, outcomes, [[]] * len(outcomes))
    header = "| grid point | planned | draws run | successes | failed | rate | Wilson 95 % | refused as impossible |"
    assert f"{header} not run |" in report and "| base | 6 | 4 | 2 | 2 | 50 % | 15 % - 85 % | 1 | 1 |" in report


def test_each_set_of_draws_has_its_own_seed_and_directory_and_a_set_not_in_the_file_needs_a_seed(tmp_path):
    path = tmp_path / "study.yaml"
    text = STUDY.read_text().replace("../scenarios", str(ROOT / "scenarios"))
    path.write_text(
        text.replace("samples: 4\nseed: 7", "draws:\n  dev: {seed: 7, samples: 4}\n  validation: {seed: 8, samples: 3}")
    )
    dev = plan_study(path, Options(progress=False))
    validation = plan_study(path, Options(draws="validation", progress=False))
    assert dev.out == Path("results/studies/smoke_box_lift/dev") and len(dev.runs) == 4
    assert validation.out == Path("results/studies/smoke_box_lift/validation") and len(validation.runs) == 3
    assert {r.sample.seed for r in validation.runs} == {8}
    assert not {r.key for r in dev.runs} & {r.key for r in validation.runs}  # other scenes
    with pytest.raises(ScenarioError, match="--draws test: not a set of the study file"):
        plan_study(path, Options(draws="test", progress=False))
    test = plan_study(path, Options(draws="test", seed=11, samples=2, progress=False))
    assert test.out == Path("results/studies/smoke_box_lift/test") and len(test.runs) == 2


def test_a_study_over_a_base_scenario_of_the_old_schema_says_so_once_with_its_renames(tmp_path, capsys):
    (tmp_path / "old.yaml").write_text(
        "name: old\nrobot: {preset: eva, home_deg: {LARM_JOINT2: -30, RARM_JOINT2: -30}}\nreference: {type: hold}\n"
        "sim: {duration: 0.2}\n"
    )
    path = tmp_path / "study.yaml"
    path.write_text(
        "name: old_base\nscenario: old.yaml\nsamples: 1\nseed: 1\n"
        "vary:\n  robot.base_pose: {uniform: [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], relative: true}\n"
    )
    _, sampler = _sampler(path)
    assert len(sampler.notices) == 1 and "robot.home_deg -> robot.home" in sampler.notices[0]
    plan_study(path, Options(tmp_path / "out", 1, None, None, None, None, (), "none", False))
    printed = capsys.readouterr()
    warned = [line for line in (printed.out + printed.err).splitlines() if "robot.home_deg -> robot.home" in line]
    assert len(warned) == 1 and warned[0].startswith("warning:")


def test_the_report_lists_the_draws_two_grid_points_disagree_on_with_each_reason(tmp_path):
    outcomes = {  # sample -> (pybullet, mujoco)
        0: ("success", "success"),
        1: ("dropped", "success"),
        2: ("success", "stalled"),
        3: ("dropped", "dropped"),
        4: ("impossible", "impossible"),
        5: ("success", "interrupted"),
    }
    rows = [
        {
            "point": f"sim.engine={engine}",
            "sample": sample,
            "success": None if outcome == "interrupted" else outcome == "success",
            "outcome": outcome,
            "reason": None if outcome == "success" else f"{engine} says {outcome}",
            "resamples": 0,
            "rejected": "[]",
            "run_dir": str(tmp_path / f"runs/s{sample}-{engine}"),
        }
        for sample, pair in outcomes.items()
        for engine, outcome in zip(("pybullet", "mujoco"), pair)
    ]
    pd.DataFrame(rows).to_parquet(tmp_path / TABLE)
    write_report(tmp_path)
    report = (tmp_path / "report.md").read_text()
    # samples 0-3 have a result in both engines (4 was refused, 5 was cut off in one); 1 and 2 disagree
    assert "## Draws the grid points disagree on (2 of 4)" in report, report
    assert "| 1 | dropped | success | sim.engine=pybullet: pybullet says dropped |" in report
    assert "| 2 | success | stalled | sim.engine=mujoco: mujoco says stalled |" in report


def test_a_grid_axis_from_the_command_line_crosses_every_sample_with_its_values(tmp_path):
    plan = plan_study(STUDY, Options(out=tmp_path, samples=2, progress=False, grid=("mpc.knots=6,26",)))
    assert [(run.sample.index, run.point.values) for run in plan.runs] == [
        (0, {"mpc.knots": 6}),
        (0, {"mpc.knots": 26}),
        (1, {"mpc.knots": 6}),
        (1, {"mpc.knots": 26}),
    ]
    with pytest.raises(ScenarioError, match="--grid 'mpc.knots'"):
        plan_study(STUDY, Options(out=tmp_path, samples=2, progress=False, grid=("mpc.knots",)))
    with pytest.raises(ScenarioError, match="both varied and a grid axis"):
        plan_study(STUDY, Options(out=tmp_path, samples=2, progress=False, grid=("world.box.mass=1,2",)))
