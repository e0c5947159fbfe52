"""`harmony bench`'s closed-loop part: every experiment run closed loop in each physics engine asked for, one after
another in this process, timed from its steps.csv — the loop (observation to command) and each part of a step,
with their tails — and the run's wall time and real-time factor, beside the last bench's numbers when this machine
measured them."""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from harmony_cli.experiment.run_dir import machine_meta
from harmony_cli.provenance import Made, record
from harmony_cli.report.timing_plots import PARTS as STEP_PARTS

PARTS = {"loop_ms": "loop (planner + whole-body MPC)"} | STEP_PARTS  # the loop, then steps.csv's breakdown
QUANTILES = {"median": 50, "p95": 95, "p99": 99, "p99.9": 99.9}


def tail_stats(values) -> dict[str, float]:
    """Median, p95, p99, p99.9 and max of a series of times [ms]."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {name: float("nan") for name in [*QUANTILES, "max"]}
    return {name: float(np.percentile(v, q)) for name, q in QUANTILES.items()} | {"max": float(v.max())}


def time_experiment(path: Path, engine: str | None = None) -> dict:
    """One experiment closed loop (no video, its plots as `harmony run` makes them) in `engine` (None: the
    scenario's): its timing report, named `<scenario name> [<engine>]`."""
    import pandas as pd

    from harmony_cli.experiment.run import run_scenario
    from harmony_cli.scenario import load_scenario

    overrides = [] if engine is None else [f"sim.engine={engine}"]
    engine = load_scenario(path, overrides).sim.engine
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run_dir = run_scenario(path, overrides, Path(tmp) / "run", progress=False)
        wall = time.perf_counter() - start
        steps = pd.read_csv(run_dir / "steps.csv")
        summary = json.loads((run_dir / "summary.json").read_text())
    simulated = float(steps["t"].iloc[-1] - steps["t"].iloc[0]) + float(np.median(np.diff(steps["t"])))
    return {
        "scenario": str(path),
        "name": f"{summary['name']} [{engine}]",
        "engine": engine,
        "steps": len(steps),
        "wall_s": wall,
        "loop_wall_s": summary["wall_time_s"],
        "physics_pct_of_loop_wall": 100 * float(steps["previous_physics_ms"].sum()) / 1e3 / summary["wall_time_s"],
        "real_time_factor": simulated / wall,
        "success": summary.get("task", {}).get("success"),
        "parts_ms": {label: tail_stats(steps[column]) for column, label in PARTS.items() if column in steps},
    } | replay_cost(steps)


def replay_cost(steps) -> dict:
    """replay.npz's per-step logging (median / p95 / max) as % of the loop's median (observation to command)."""
    if "previous_replay_ms" not in steps:
        return {}
    loop = float(np.median(steps["loop_ms"]))
    stats = tail_stats(steps["previous_replay_ms"].iloc[1:])  # the first row has no step before
    return {"replay_log_pct_of_loop_median": {k: 100 * stats[k] / loop for k in ("median", "p95", "max")}}


def _previous(out: Path | None, meta: dict) -> dict[str, dict]:
    """The last bench's experiments by name, if this machine (same CPU model) measured them."""
    if out is None or not out.is_file():
        return {}
    try:
        last = json.loads(out.read_text())
    except (OSError, ValueError):
        return {}
    if last.get("meta", {}).get("cpu") != meta["cpu"]:
        return {}
    return {e["name"]: e | {"git_sha": last["meta"].get("git_sha")} for e in last.get("experiments", [])}


def _row(label: str, stats: dict, before: dict | None) -> list[str]:
    cells = [f"{stats[k]:.2f}" for k in [*QUANTILES, "max"]]
    if before:
        cells.append(f"{before['median']:.2f} / {before['p99']:.2f} / {before['max']:.2f}")
    return [label, *cells]


def run_loop_bench(
    paths: list[Path],
    out: Path | None = None,
    console: Console | None = None,
    engines: list[str | None] | None = None,
) -> dict:
    """Each experiment closed loop in each of `engines` (default: the scenario's), one at a time; prints a table
    per run and writes `out` (JSON)."""
    console = console or Console(width=160)
    meta = machine_meta(1)
    previous = _previous(out, meta)
    experiments = []
    for path, engine in ((path, engine) for engine in engines or [None] for path in paths):
        console.print(f"[bold]{path}[/bold]{f' in {engine}' if engine else ''}: running closed loop ...")
        report = time_experiment(path, engine)
        experiments.append(report)
        before = previous.get(report["name"])
        table = Table(
            title=f"{report['name']}: {report['steps']} steps, wall {report['wall_s']:.1f} s (closed loop "
            f"{report['loop_wall_s']:.1f} s, physics {report['physics_pct_of_loop_wall']:.0f} % of it), "
            f"{report['real_time_factor']:.2f}x real time, success {report['success']} (ms)"
        )
        for column in ["", *QUANTILES, "max"] + (
            [f"last bench ({before['git_sha'][:7]}) p50/p99/max"] if before else []
        ):
            table.add_column(column, justify="right")
        for label, stats in report["parts_ms"].items():
            table.add_row(*_row(label, stats, before["parts_ms"].get(label) if before else None))
        console.print(table)
        if cost := report.get("replay_log_pct_of_loop_median"):
            console.print(
                "replay log (replay.npz) per step, % of the loop median: "
                + ", ".join(f"{k} {v:.2f} %" for k, v in cost.items())
            )
    console.print(f"{meta['cpu']}, {meta['cores']} cores, git {meta['git_sha']}")
    result = {"meta": meta, "experiments": experiments}
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=2))
        record([out], Made.here())
    return result
