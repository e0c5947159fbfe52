"""The helper processes that draw a run's figures while the run writes its tables (experiment/figure_process.py)."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import pandas as pd
import pytest

from harmony_cli.experiment.figure_process import FigureJob, FigureProcesses
from harmony_cli.experiment.run import run_scenario
from harmony_cli.report.plots import plot_run_dir
from harmony_cli.scenario import load_scenario

SCENARIO = Path(__file__).parents[1] / "harmony_cli/examples/scenarios/paper/pick_and_carry.yaml"


@pytest.fixture(scope="module")
def job(tmp_path_factory) -> FigureJob:
    """A short pick_and_carry run's steps, scenario and summary (MuJoCo, 3 s), to draw from again."""
    out = tmp_path_factory.mktemp("figures") / "run"
    run_scenario(SCENARIO, ["sim.engine=mujoco", "sim.duration=3"], out, progress=False, plots="none")
    scenario = load_scenario(out / "scenario.resolved.yaml", runnable=False)
    summary = json.loads((out / "summary.json").read_text())
    return FigureJob(out, pd.read_csv(out / "steps.csv"), scenario, summary)


def _drawn(directory: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in sorted(directory.glob("*.png"))}


def test_helpers_draw_the_figures_the_run_draws_itself_to_the_byte(job, tmp_path):
    alone, shared = tmp_path / "alone", tmp_path / "shared"
    alone.mkdir(), shared.mkdir()
    plot_run_dir(alone, job.steps, job.scenario, job.summary)
    helpers = FigureProcesses(parts=2)
    try:
        helpers.send(FigureJob(shared, job.steps, job.scenario, job.summary))
        helpers.wait()
    finally:
        helpers.close()
    assert len(_drawn(alone)) >= 5 and _drawn(shared) == _drawn(alone)


def test_the_parts_of_a_run_directorys_figures_are_disjoint_and_together_all_of_them(job, tmp_path):
    parts = [tmp_path / str(part) for part in range(3)]
    for part, directory in enumerate(parts):
        directory.mkdir()
        plot_run_dir(directory, job.steps, job.scenario, job.summary, part, len(parts))
    names = [set(_drawn(directory)) for directory in parts]
    everything = tmp_path / "all"
    everything.mkdir()
    plot_run_dir(everything, job.steps, job.scenario, job.summary)
    assert sum(map(len, names)) == len(set().union(*names)) and set().union(*names) == set(_drawn(everything))


def test_a_helpers_error_comes_back_to_the_run_as_the_exception_it_raised(job, tmp_path):
    helpers = FigureProcesses(parts=1)
    try:
        helpers.send(FigureJob(tmp_path, job.steps.drop(columns=["solve_ms"]), job.scenario, job.summary))
        with pytest.raises(KeyError, match="solve_ms"):
            helpers.wait()
    finally:
        helpers.close()


def test_helpers_sent_no_job_end_cleanly_when_closed():
    helpers = FigureProcesses(parts=2)
    helpers.close()
    assert [child.returncode for child in helpers.children] == [0, 0]


def test_a_helper_that_has_gone_makes_sending_the_job_fail_so_that_the_run_draws_the_figures_itself(job, tmp_path):
    helpers = FigureProcesses(parts=2)
    helpers.children[1].kill()
    helpers.children[1].wait()
    try:
        assert helpers.send(FigureJob(tmp_path, job.steps, job.scenario, job.summary)) is False
    finally:
        helpers.close()


def _ignores_interrupt(pid: int) -> bool:
    """Whether process `pid` ignores SIGINT (Linux: the SigIgn mask in /proc/<pid>/status)."""
    status = Path(f"/proc/{pid}/status").read_text()
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigIgn:")), 16)
    return bool(mask >> (signal.SIGINT - 1) & 1)


def test_a_helper_leaves_the_terminals_interrupt_to_the_run_and_still_draws_its_share(job, tmp_path):
    helpers = FigureProcesses(parts=1)
    try:
        child = helpers.children[0]
        deadline = time.monotonic() + 60.0
        while not _ignores_interrupt(child.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        os.kill(child.pid, signal.SIGINT)  # what Ctrl-C sends the run's whole process group
        assert helpers.send(FigureJob(tmp_path, job.steps, job.scenario, job.summary))
        helpers.wait()
    finally:
        helpers.close()
    assert len(_drawn(tmp_path)) >= 5
