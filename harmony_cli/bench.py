"""`harmony bench`: whole-body MPC solve time, both transcriptions x K x solver modes, side by side in one run.

Each configuration replays the same kinematic closed loop (the command is executed exactly) along the
scenario's reference, one configuration at a time in this process, so the ratios compare like with like.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from harmony_cli.loop import hand_reference_matrix
from harmony_cli.metrics import time_stats_ms
from harmony_cli.reference import HandReference
from harmony_cli.robot import load_robot
from harmony_cli.run import machine_meta
from harmony_cli.scenario import load_scenario
from harmony_cli.wholebody import WholeBodyMPC

TRANSCRIPTIONS = ("traditional", "bezier")


def measure(path: Path, overrides: list[str], steps: int, start: float) -> dict:
    scenario = load_scenario(path, overrides)
    robot = load_robot(scenario.robot, path.parent)
    mpc = WholeBodyMPC(robot, scenario, scenario.sim.control_dt)
    reference = HandReference(scenario.reference, robot.hand_poses_numeric(robot.home))
    q, times, iterations, failures = robot.home.copy(), [], [], 0
    for k in range(steps):
        t = start + k * scenario.sim.control_dt
        command, result = mpc.step(q, hand_reference_matrix(*reference.poses(t + mpc.knot_times)))
        q = command.q
        times.append(1e3 * result.solve_time)
        iterations.append(result.iterations)
        failures += not result.success
    qp = getattr(mpc.solver, "qp_name", None)
    return {"n_vars": mpc.problem.n_vars, "build_s": mpc.build_time, "failures": failures, "qp": qp,
            "iterations": float(np.median(iterations)), **time_stats_ms(times)}


def run_bench(path: Path, knots: list[int], solvers: list[str], steps: int, start: float,
              out: Path | None = None, console: Console | None = None) -> dict:
    console = console or Console(width=160)
    results = {}
    configs = [(s, tr, k) for s in solvers for k in knots for tr in TRANSCRIPTIONS]
    with Progress(console=console, transient=True) as bar:
        task = bar.add_task("benchmark", total=len(configs))
        for solver, tr, k in configs:
            overrides = [f"mpc.transcription={tr}", f"mpc.knots={k}", f"solver.name={solver}"]
            results[(solver, tr, k)] = measure(path, overrides, steps, start)
            bar.advance(task)

    title = f"Whole-body MPC solve time [ms], {steps} steps each, one configuration at a time"
    columns = ("solver", "transcription", "K", "vars", "median", "p95", "max", "iters", "failed",
               "trad/bezier (median)", "K26/K6 (median)")
    table = Table(title=title)
    for col in columns:
        table.add_column(col, justify="right")
    rows = []
    for (solver, tr, k), r in results.items():
        other = results.get((solver, "bezier", k)) if tr == "traditional" else None
        ratio_tb = f"{r['median'] / other['median']:.2f}" if other else ""
        small, large = results.get((solver, tr, min(knots))), results.get((solver, tr, max(knots)))
        ratio_k = f"{large['median'] / small['median']:.2f}" if k == max(knots) and small and len(knots) > 1 else ""
        label = f"{solver} ({r['qp']})" if r["qp"] else solver
        rows.append([label, tr, str(k), str(r["n_vars"]), f"{r['median']:.2f}", f"{r['p95']:.2f}",
                     f"{r['max']:.2f}", f"{r['iterations']:.0f}", str(r["failures"]), ratio_tb, ratio_k])
        table.add_row(*rows[-1])
    console.print(table)
    meta = machine_meta(1)
    machine = f"{meta['cpu']}, {meta['cores']} cores, git {meta['git_sha']}"
    console.print(machine)
    report = {"meta": meta, "steps": steps,
              "results": [{"solver": s, "transcription": tr, "knots": k, **r} for (s, tr, k), r in results.items()]}
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(report, indent=2))
        markdown = "| " + " | ".join(columns) + " |\n|" + "---|" * len(columns) + "\n"
        markdown += "".join("| " + " | ".join(row) + " |\n" for row in rows)
        out.with_suffix(".md").write_text(f"# {title}\n\n{markdown}\n{machine}\n")
    return report
