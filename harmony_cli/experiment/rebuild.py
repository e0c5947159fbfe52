"""`harmony summarise RUN_DIR`: steps.csv, summary.json and the plots rebuilt from the streamed steps.jsonl, for
a run killed hard (SIGKILL, out of memory, power) before it could write them."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from harmony_cli.experiment.results import RunRecord, write_results
from harmony_cli.experiment.stream import STREAM, read_stream
from harmony_cli.report.plots import plot_run_dir
from harmony_cli.scenario import load_scenario

REBUILT = "rebuilt from steps.jsonl after the run stopped without writing its summary"


def _json(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def rebuild_run_dir(run_dir: Path) -> dict:
    """Rebuild `run_dir`'s results from steps.jsonl, scenario.resolved.yaml and meta.json; returns the summary. A
    run that left a summary keeps its status (completed, failed, interrupted); one that left none is "killed"."""
    if not (run_dir / STREAM).is_file():
        raise FileNotFoundError(f"{run_dir}: no {STREAM} (not a run directory, or made before runs streamed steps)")
    scenario = load_scenario(run_dir / "scenario.resolved.yaml", runnable=False)
    rows = read_stream(run_dir / STREAM)
    summary = _json(run_dir / "summary.json") or {"name": scenario.name, "status": "killed", "reason": REBUILT}
    if rows and "wall_clock_s" in rows[0] and "wall_time_s" not in summary:
        summary["wall_time_s"] = rows[-1]["wall_clock_s"] - rows[0]["wall_clock_s"]  # first to last record
    twin_csv = run_dir / "push_free" / "steps.csv"  # a push-free twin runs first and is complete if the run started
    twin = pd.read_csv(twin_csv) if twin_csv.is_file() else None
    meta = _json(run_dir / "meta.json") or {}  # written after the build, so a killed run has it
    steps = write_results(RunRecord(run_dir, scenario, run_dir, rows, summary, meta, twin))
    if len(steps):
        plot_run_dir(run_dir, steps, scenario, summary)
    with (run_dir / "run.log").open("a") as log:
        log.write(f"harmony summarise: {len(rows)} steps from {STREAM}; status: {summary['status']}\n")
    return summary
