"""Committed results name the code that made them, and the lint check tells stale ones from fresh ones."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from harmony_cli.provenance import FILE, Made, code_version, copy, cpu_model, made_of, record

ROOT = Path(__file__).resolve().parents[1]


def _check_results():
    spec = importlib.util.spec_from_file_location("check_results", ROOT / "tools" / "check_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(directory: Path, version: str, cpu: str = "CPU A") -> Path:
    directory.mkdir(parents=True)
    meta = {"code_version": version, "git_sha": "abc", "cpu": cpu}
    (directory / "meta.json").write_text(json.dumps(meta))
    (directory / "force_tracking.png").write_bytes(b"png")
    return directory


def test_a_result_made_from_runs_names_their_code_and_cpus(tmp_path):
    runs = [_run(tmp_path / "a", "0.2.0+1", "CPU A"), _run(tmp_path / "b", "0.2.0+1", "CPU B")]
    table = tmp_path / "table.md"
    table.write_text("| a |")
    record([table], Made.from_runs(runs))
    made = made_of(table)
    assert made is not None and made.code_version == "0.2.0+1" and made.cpu == "CPU A, CPU B"


def test_recording_one_file_keeps_the_entries_of_the_others(tmp_path):
    first, second = tmp_path / "one.md", tmp_path / "two.md"
    record([first], Made("0.1.0+old", "a", "cpu", "2026-01-01"))
    record([second], Made.here())
    assert json.loads((tmp_path / FILE).read_text()).keys() == {"one.md", "two.md"}
    assert made_of(first).code_version == "0.1.0+old"


def test_a_copy_of_a_runs_file_carries_the_runs_code_version(tmp_path):
    run = _run(tmp_path / "run", "0.2.0+run")
    (tmp_path / "paper").mkdir()
    target = copy(run / "force_tracking.png", tmp_path / "paper" / "pick_and_carry_force.png")
    assert target.read_bytes() == b"png" and made_of(target).code_version == "0.2.0+run"


def test_the_check_names_stale_and_unrecorded_results_with_the_command_that_remakes_them(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    paper, bench = Path("results/paper"), Path("results/bench")
    paper.mkdir(parents=True)
    bench.mkdir(parents=True)
    for path in (paper / "table1.md", paper / "experiments.md", bench / "bench.json"):
        path.write_text("x")
    record([paper / "table1.md"], Made.here())
    record([paper / "experiments.md"], Made("0.1.0+old", "a", "cpu", "2026-01-01"))
    lines = _check_results().problems(
        [paper / "table1.md", paper / "experiments.md", bench / "bench.json"], code_version()
    )
    assert len(lines) == 2
    assert "results/bench" in lines[0] and "no provenance entry" in lines[0] and "make bench" in lines[0]
    assert "results/paper" in lines[1] and "0.1.0+old" in lines[1] and "make reproduce-paper" in lines[1]


def test_results_made_by_the_code_as_it_is_pass_the_check(tmp_path):
    table = tmp_path / "table.md"
    table.write_text("x")
    record([table], Made.here())
    assert _check_results().problems([table], code_version()) == []


def _study_table(directory: Path) -> Path:
    import pandas as pd

    from harmony_cli.study.table import TABLE

    table = pd.DataFrame(
        {
            "point": ["base"] * 2,
            "sample": [0, 1],
            "success": [True, False],
            "outcome": ["success", "dropped"],
            "reason": ["", "the box fell"],
            "resamples": [0, 0],
            "run_dir": [str(directory / f"runs/s{i}") for i in range(2)],
        }
    )
    table.to_parquet(directory / TABLE)
    return directory / TABLE


def test_a_study_report_takes_its_tables_entry_and_an_unrecorded_table_leaves_it_unrecorded(tmp_path):
    from harmony_cli.study.report import write_report

    recorded, unrecorded = tmp_path / "recorded", tmp_path / "unrecorded"
    for directory in (recorded, unrecorded):
        directory.mkdir()
        _study_table(directory)
    old = Made("0.1.0+old", "a", "CPU A", "2026-01-01")
    record([recorded / "study.parquet"], old)
    assert all(made_of(path) == old for path in write_report(recorded))
    assert all(made_of(path) is None for path in write_report(unrecorded))


def test_make_results_runs_every_target_the_check_can_ask_for():
    asked = {command.removeprefix("make ") for command in _check_results().REMAKE.values()}
    line = next(line for line in (ROOT / "Makefile").read_text().splitlines() if line.startswith("results:"))
    assert asked <= set(line.split(":", 1)[1].split())


def test_cpu_string_tells_apart_two_cpus_that_share_a_model_name(tmp_path):
    def cpuinfo(family: int, model: int) -> Path:
        path = tmp_path / f"cpuinfo_{family}_{model}"
        fields = {"processor": 0, "cpu family": family, "model": model, "model name": "AMD EPYC", "stepping": 1}
        path.write_text("".join(f"{key}\t: {value}\n" for key, value in fields.items()))
        return path

    older, newer = cpu_model(cpuinfo(25, 17)), cpu_model(cpuinfo(26, 2))
    assert older.startswith("AMD EPYC") and newer.startswith("AMD EPYC")
    assert older != newer
