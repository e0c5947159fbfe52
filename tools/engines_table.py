"""The same scenarios run in each physics engine, side by side: results/engines/engines.md from the run directories
`make engines` writes (RUNS/<engine>/<scenario>/summary.json and meta.json).

    python tools/engines_table.py RUNS --out results/engines/engines.md
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from harmony_cli.provenance import Made, record

COLUMNS = (  # (heading, value from a run's summary)
    ("outcome", lambda s: _outcome(s)),
    ("box goal error [cm]", lambda s: _cm(s.get("task", {}).get("box_goal_error_m"))),
    ("min clearance robot / box [cm]", lambda s: _clearances(s.get("task", {}).get("min_clearance_m") or {})),
    ("max tracking error [cm]", lambda s: _cm(s.get("tracking_error", {}).get("max_m"))),
)


def _outcome(summary: dict) -> str:
    if summary.get("status") != "completed":
        return f"{summary.get('status')}: {summary.get('failure')}"
    task = summary.get("task")
    if task is not None:
        return "success" if task.get("success") else f"failed: {(task.get('failure') or {}).get('category')}"
    return f"tracking {summary.get('tracking', {}).get('verdict')}"


def _cm(metres) -> str:
    return "-" if metres is None or (isinstance(metres, float) and math.isnan(metres)) else f"{100 * metres:.2f}"


def _clearances(per_obstacle: dict) -> str:
    if not per_obstacle:
        return "-"
    robot = min(v["robot"] for v in per_obstacle.values() if v.get("robot") is not None)
    boxes = [v["box"] for v in per_obstacle.values() if v.get("box") is not None]
    return f"{_cm(robot)} / {_cm(min(boxes)) if boxes else '-'}"


def table(runs: Path) -> str:
    engines = sorted(
        (p.name for p in runs.iterdir() if p.is_dir()), key=lambda e: (e != "pybullet", e)
    )  # the default first
    scenarios = list(dict.fromkeys(p.name for e in engines for p in sorted((runs / e).iterdir()) if p.is_dir()))
    summaries = {
        (e, s): json.loads((runs / e / s / "summary.json").read_text())
        for e in engines
        for s in scenarios
        if (runs / e / s / "summary.json").is_file()
    }
    head = ["scenario"] + [f"{heading}: {engine}" for heading, _ in COLUMNS for engine in engines]
    lines = ["# The same scenarios in each physics engine", "", "| " + " | ".join(head) + " |"]
    lines.append("|---" * len(head) + "|")
    for s in scenarios:
        cells = [s] + [
            value(summaries[(e, s)]) if (e, s) in summaries else "not run" for _, value in COLUMNS for e in engines
        ]
        lines.append("| " + " | ".join(cells) + " |")
    metas = [json.loads(p.read_text()) for p in sorted(runs.glob("*/*/meta.json"))]
    cpus = sorted({m.get("cpu", "?") for m in metas})
    commits = sorted({m.get("git_sha", "?")[:7] for m in metas})
    lines += [
        "",
        f"Measured by harmony on {', '.join(cpus)} at commit {', '.join(commits)}; outcomes only (speeds: make bench).",
    ]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(table(args.runs))
    record([args.out], Made.from_runs(p.parent for p in sorted(args.runs.glob("*/*/meta.json"))))
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
