"""Ablation grids for `harmony compare`: expand key=v1,v2 axes and run each point (in parallel with --jobs)."""

from __future__ import annotations

import itertools
import json
from concurrent.futures import as_completed
from pathlib import Path

from rich.progress import Progress
from rich.text import Text

from harmony_cli.experiment.interrupts import RunInterrupted, signals_end_the_run
from harmony_cli.experiment.run import run_scenario
from harmony_cli.experiment.workers import end_workers, worker_pool
from harmony_cli.report.tracking import tracking_failed
from harmony_cli.scenario import apply_overrides, grid_axis


def expand_grid(axes: list[str]) -> list[list[str]]:
    """['a=1,2', 'b=x,y'] -> [['a=1','b=x'], ['a=1','b=y'], ['a=2','b=x'], ['a=2','b=y']]."""
    parsed = [[f"{key}={v}" for v in values] for key, values in map(grid_axis, axes)]
    return [list(point) for point in itertools.product(*parsed)]


def point_label(point: list[str]) -> str:
    return "_".join(f"{key.split('.')[-1]}-{value}" for key, _, value in (i.partition("=") for i in point)) or "base"


def _run_quiet(path: str, overrides: list[str], out: Path, jobs: int) -> Path:
    return run_scenario(path, overrides, out, progress=False, concurrency=jobs)


def run_grid(path: str | Path, axes: list[str], base_overrides: list[str], out: Path, jobs: int = 1) -> list[Path]:
    """Run every grid point into out/runs/<label>; returns the run directories (failed runs included)."""
    points = expand_grid(axes)
    apply_overrides({}, base_overrides)  # reject malformed --set before any work starts
    dirs = [out / "runs" / point_label(p) for p in points]
    jobs_list = [(str(path), list(base_overrides) + p, d) for p, d in zip(points, dirs)]
    with Progress() as bar:
        task = bar.add_task(f"{len(points)} runs, {jobs} at a time", total=len(points))
        if jobs <= 1:
            for p, o, d in jobs_list:
                try:
                    _run_quiet(p, o, d, 1)
                except Exception as exc:  # noqa: BLE001 - the run directory holds the status and log
                    bar.console.print(Text(f"{d.name} failed: {exc}", style="red"))
                bar.advance(task)
        else:
            _run_pool(jobs_list, jobs, bar, task)
    return dirs


def _run_pool(jobs_list: list, jobs: int, bar: Progress, task) -> None:
    """The grid on `jobs` worker processes. A signal to this process ends every worker's run cleanly (each
    worker keeps its run's steps and says interrupted), cancels the points not started, then propagates."""
    with signals_end_the_run(), worker_pool(jobs) as pool:
        try:
            futures = {pool.submit(_run_quiet, p, o, d, jobs): d for p, o, d in jobs_list}
            for future in as_completed(futures):
                if future.exception():
                    bar.console.print(Text(f"{futures[future].name} failed: {future.exception()}", style="red"))
                bar.advance(task)
        except RunInterrupted:
            end_workers(pool)
            raise


def failed_runs(dirs: list[Path]) -> list[str]:
    """'label (status: reason)' for every grid run that did not complete or whose hands left the reference's
    tolerance (report/tracking.py)."""
    failed = []
    for d in dirs:
        try:
            summary = json.loads((d / "summary.json").read_text())
        except (OSError, ValueError):
            summary = {"status": "no summary.json"}
        if summary.get("status") != "completed":
            why = summary.get("reason") or summary.get("error") or ""  # interrupted runs give a reason only
            failed.append(f"{d.name} ({summary.get('status')}: {why})")
        elif tracking_failed(summary):
            failed.append(f"{d.name} (tracking failed: {summary['tracking']['reason']})")
    return failed
