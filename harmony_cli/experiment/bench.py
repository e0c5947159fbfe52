"""`harmony bench`: whole-body MPC solve time, both transcriptions x K x solver modes, side by side in one run.

Each configuration replays the same kinematic closed loop (the command is executed exactly) along the
scenario's reference; the configurations take turns step by step in this one process, so the ratios
compare like with like even when the machine's speed drifts.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from harmony_cli.experiment.run_dir import machine_meta
from harmony_cli.mpc.knot_params import hand_rows
from harmony_cli.mpc.structures import forget_structures
from harmony_cli.mpc.wholebody import WholeBodyMPC
from harmony_cli.provenance import Made, record
from harmony_cli.report.metrics import time_stats_ms
from harmony_cli.robot.model import load_robot
from harmony_cli.scenario import load_scenario
from harmony_cli.tasks.reference import HandReference

TRANSCRIPTIONS = ("traditional", "bezier")


class Replay:
    """One configuration replaying a kinematic closed loop (the command is executed exactly)."""

    def __init__(self, path: Path, overrides: list[str], start: float):
        scenario = load_scenario(path, overrides)
        self.robot = load_robot(scenario.robot, path.parent)
        forget_structures()  # each configuration's build is measured from scratch (build_s), none reused
        self.mpc = WholeBodyMPC(self.robot, scenario, scenario.sim.control_dt)
        if scenario.reference is None:
            raise ValueError(f"{path}: the bench replays a hand reference; this scenario has a task")
        self.reference = HandReference(scenario.reference, self.robot.hand_poses_numeric(self.robot.home))
        self.dt, self.start, self.q = scenario.sim.control_dt, start, self.robot.home.copy()
        self.times: list[float] = []
        self.iterations: list[int] = []
        self.failures = 0

    def step(self, k: int) -> None:
        t = self.start + k * self.dt
        command, result = self.mpc.step(self.q, hand_rows(*self.reference.poses(t + self.mpc.knot_times)))
        self.q = command.q
        self.times.append(1e3 * result.solve_time)
        self.iterations.append(result.iterations)
        self.failures += not result.success

    def summary(self) -> dict:
        return {
            "n_vars": self.mpc.problem.n_vars,
            "build_s": self.mpc.build_time,
            "failures": self.failures,
            "qp": getattr(self.mpc.solver, "qp_name", None),
            "iterations": float(np.median(self.iterations)),
            **time_stats_ms(self.times),
        }


COLUMNS = ("solver", "transcription", "K", "vars", "median", "p95", "max", "iters", "failed")
RATIOS = ("trad/bezier (median)", "K26/K6 (median)")


def _interleaved(path: Path, knots: list[int], solvers: list[str], steps: int, start: float, console: Console) -> dict:
    """Every (solver, transcription, K) replayed for `steps` steps, step k of each before step k + 1 of any, so
    that drift in the machine's speed hits all alike; their summaries."""
    configs = [(s, tr, k) for s in solvers for k in knots for tr in TRANSCRIPTIONS]
    with Progress(console=console, transient=True) as bar:
        task = bar.add_task("building", total=len(configs))
        replays = {}
        for solver, tr, k in configs:
            overrides = [f"mpc.transcription={tr}", f"mpc.knots={k}", f"solver.name={solver}"]
            replays[(solver, tr, k)] = Replay(path, overrides, start)
            bar.advance(task)
        task = bar.add_task("solving", total=steps)
        for k in range(steps):
            for replay in replays.values():
                replay.step(k)
            bar.advance(task)
    return {config: replay.summary() for config, replay in replays.items()}


def _rows(results: dict, knots: list[int]) -> list[list[str]]:
    """One row per configuration with the trad/bezier and largest/smallest K ratios of the medians."""
    rows = []
    for (solver, tr, k), r in results.items():
        other = results.get((solver, "bezier", k)) if tr == "traditional" else None
        ratio_tb = f"{r['median'] / other['median']:.2f}" if other else ""
        small, large = results.get((solver, tr, min(knots))), results.get((solver, tr, max(knots)))
        ratio_k = ""
        if k == max(knots) and small and large and len(knots) > 1:
            ratio_k = f"{large['median'] / small['median']:.2f}"
        label = f"{solver} ({r['qp']})" if r["qp"] else solver
        times = [f"{r[key]:.2f}" for key in ("median", "p95", "max")]
        rows.append([label, tr, str(k), str(r["n_vars"]), *times, f"{r['iterations']:.0f}", str(r["failures"])])
        rows[-1] += [ratio_tb, ratio_k]
    return rows


def run_bench(
    path: Path,
    knots: list[int],
    solvers: list[str],
    steps: int,
    start: float,
    out: Path | None = None,
    console: Console | None = None,
) -> dict:
    console = console or Console(width=160)
    results = _interleaved(path, knots, solvers, steps, start, console)
    title = f"Whole-body MPC solve time (ms), {steps} steps each, configurations interleaved step by step"
    columns, rows = COLUMNS + RATIOS, _rows(results, knots)
    table = Table(title=title)
    for col in columns:
        table.add_column(col, justify="right")
    for row in rows:
        table.add_row(*row)
    console.print(table)
    meta = machine_meta(1)
    machine = f"{meta['cpu']}, {meta['cores']} cores, git {meta['git_sha']}"
    console.print(machine)
    listed = [{"solver": s, "transcription": tr, "knots": k, **r} for (s, tr, k), r in results.items()]
    report = {"meta": meta, "steps": steps, "results": listed}
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(report, indent=2))
        markdown = "| " + " | ".join(columns) + " |\n|" + "---|" * len(columns) + "\n"
        markdown += "".join("| " + " | ".join(row) + " |\n" for row in rows)
        out.with_suffix(".md").write_text(f"# {title}\n\n{markdown}\n{machine}\n")
        record([out, out.with_suffix(".md")], Made.here())
    return report
