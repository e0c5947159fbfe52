"""The end of a run: steps.csv, the summary's metrics, summary.json, meta.json, run.log and the plots, each written
as far as it can be (one write that fails does not stop the others). pandas and the plots load here, after the
closed loop, not before its first step."""

from __future__ import annotations

import json
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING

from harmony_cli.experiment.faults import Writes, write_whole
from harmony_cli.experiment.figure_process import FigureJob, FigureProcesses
from harmony_cli.experiment.replay_log import REPLAY, ReplayLog
from harmony_cli.experiment.stream import STREAM, StepStream
from harmony_cli.report.tracking import tracking_failed
from harmony_cli.robot.urdf import hand_below
from harmony_cli.scenario import Scenario, robot_of

if TYPE_CHECKING:
    import pandas as pd

    from harmony_cli.sim.video import VideoRecorder


Attempt = Callable[[str, Callable[[], object]], object]  # (file, its write): a run's end tries each (faults.Writes)


def _now(what: str, write: Callable[[], object]) -> object:
    return write()


@dataclass
class RunRecord:
    """What a run's results are written from: its directory, scenario (and the directory its paths are relative
    to), the steps so far, the summary and meta.json being built, and the push-free twin's steps if it has one."""

    out: Path
    scenario: Scenario
    scenario_dir: Path
    rows: list[dict]
    summary: dict
    meta: dict
    twin: pd.DataFrame | None = None
    replay: ReplayLog | None = None  # the knots and plans: replay.npz


def write_results(run: RunRecord, attempt: Attempt = _now) -> pd.DataFrame:
    """steps.csv (with push displacements from the twin), the summary's metrics, summary.json and meta.json, each
    written through `attempt` (at a run's end: one that fails does not stop the others)."""
    steps = summarised(run)
    write_tables(run, steps, attempt)
    return steps


def summarised(run: RunRecord) -> pd.DataFrame:
    """The run's steps as a table (with push displacements from the twin); the summary's metrics added to
    `run.summary` from them."""
    import pandas as pd

    from harmony_cli.report.metrics import displacement_from_twin
    from harmony_cli.report.summary import summarise_run

    scenario, twin = run.scenario, run.twin
    steps = pd.DataFrame(run.rows)
    hands = list(scenario.robot.end_effectors)
    if len(steps) and twin is not None:
        steps = displacement_from_twin(steps, twin, hands)
    if len(steps):
        urdf = robot_of(scenario, run.scenario_dir).urdf
        pushed = {
            p.name: hand_below(p.link, urdf, scenario.robot.end_effectors)
            if p.body == "robot" and p.link is not None
            else None
            for p in scenario.pushes
        }
        run.summary |= summarise_run(steps, scenario, hands, pushed)
    return steps


def write_tables(run: RunRecord, steps: pd.DataFrame, attempt: Attempt = _now) -> None:
    """steps.csv, meta.json and summary.json, each written through `attempt`."""
    out = run.out
    attempt("steps.csv", lambda: steps.to_csv(out / "steps.csv", index=False))
    attempt("meta.json", lambda: write_whole(out / "meta.json", json.dumps(run.meta, indent=2)))
    attempt("summary.json", lambda: write_whole(out / "summary.json", json.dumps(run.summary, indent=2)))


def finish_run(
    run: RunRecord,
    opened: tuple[IO[str], StepStream, VideoRecorder | None],
    writes: Writes,
    plots: str = "all",
    figures: FigureProcesses | None = None,
) -> None:
    """Every result of a run that can be written (a run that fails part-way keeps its video up to there); the
    plots as `plots` asks (all | failed | none), drawn by `figures` (helper processes, ended here however the
    writes end) while the tables are written when it has them. replay.npz is compressed beside the tables (zlib
    lets the interpreter go on)."""
    try:
        _finish(run, opened, writes, plots, figures)
    finally:
        if figures is not None:
            figures.close()


def _finish(
    run: RunRecord,
    opened: tuple[IO[str], StepStream, VideoRecorder | None],
    writes: Writes,
    plots: str,
    figures: FigureProcesses | None,
) -> None:
    log, stream, recorder = opened
    out, summary = run.out, run.summary
    writes(STREAM, stream.close)
    if recorder and (video := writes("video", recorder.close)) is not None:
        summary["video"] = str(video)
    steps = summarised(run)
    drawn = len(steps) > 0 and (plots == "all" or plots == "failed" and not succeeded(summary))
    if drawn and figures is not None and not figures.send(FigureJob(out, steps, run.scenario, dict(summary))):
        figures.close()  # a helper has gone: the others finish theirs, then the run draws every figure itself
        figures = None
    with ThreadPoolExecutor(1) as pool:
        replay = None if run.replay is None else pool.submit(run.replay.write, out)
        write_tables(run, steps, writes)
        if replay is not None:
            writes(REPLAY, replay.result)
    writes("run.log", lambda: log.write(f"status: {summary['status']}\n"))
    writes("run.log", log.close)
    if drawn and figures is not None:
        writes("plots", figures.wait)
    elif drawn:
        from harmony_cli.report.plots import plot_run_dir  # matplotlib: ~1 s to import

        writes("plots", lambda: plot_run_dir(out, steps, run.scenario, summary))
    if writes.reason is not None:  # a write failed after summary.json was: it says so now
        writes("summary.json", lambda: write_whole(out / "summary.json", json.dumps(summary, indent=2)))


def succeeded(summary: dict) -> bool:
    """A run that completed, with its task's success (a hand trajectory: no failed solve and the hands within the
    reference's tolerance)."""
    task = summary.get("task")
    if task is not None:
        ok = bool(task.get("success"))
    else:
        ok = summary.get("failed_solves") == 0 and not tracking_failed(summary)
    return summary.get("status") == "completed" and ok
