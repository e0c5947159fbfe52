"""Compare the outcomes of two sets of run directories (e.g. before and after a refactor, on one machine).

    python tools/compare_runs.py BEFORE AFTER [--tol 1e-9]

Every run directory under BEFORE (found by its summary.json) is matched with the one at the same relative path
under AFTER. Compared: the summary's outcomes (decision variables, failed solves, tracking errors, task success,
box goal error, min clearances, force and push metrics) and every column of steps.csv that is not a wall-clock
time, to an absolute tolerance. Prints one line per run and every difference; exit 1 if any.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import pandas as pd

TIMING = ("_ms", "wall_time_s", "wall_clock_s", "build_time_s", "started")  # wall-clock measurements: not outcomes


def _flatten(value, prefix: str = "") -> dict:
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in _flatten(item, f"{prefix}{key}.").items()}
    if isinstance(value, list) and all(isinstance(v, (int, float)) for v in value):
        return {f"{prefix}{i}": v for i, v in enumerate(value)}
    return {prefix.rstrip("."): value}


def _timing(key: str) -> bool:
    return any(part in key for part in TIMING) or key.endswith(".dir") or key == "video"


def _differs(a, b, tol: float) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return a != b
    if math.isnan(a) or math.isnan(b):
        return not (math.isnan(a) and math.isnan(b))
    return abs(a - b) > tol


def compare_summaries(before: dict, after: dict, tol: float) -> list[str]:
    a, b = _flatten(before), _flatten(after)
    keys = sorted(k for k in set(a) | set(b) if not _timing(k))
    return [
        f"summary {k}: {a.get(k, '<absent>')} -> {b.get(k, '<absent>')}"
        for k in keys
        if k in a and k in b and _differs(a[k], b[k], tol)
    ] + [f"summary {k}: only {'before' if k in a else 'after'}" for k in keys if (k in a) != (k in b)]


def compare_steps(before: pd.DataFrame, after: pd.DataFrame, tol: float) -> tuple[list[str], int]:
    problems = []
    if len(before) != len(after):
        return [f"steps: {len(before)} rows -> {len(after)}"], 0
    common = [c for c in before.columns if c in after.columns and not _timing(c)]
    for c in common:
        x, y = before[c], after[c]
        if pd.api.types.is_numeric_dtype(x) and pd.api.types.is_numeric_dtype(y):
            diff = (x.astype(float) - y.astype(float)).abs()
            both_nan = x.isna() & y.isna()
            worst = diff[~both_nan].max() if (~both_nan).any() else 0.0
            if worst > tol or (x.isna() != y.isna()).any():
                problems.append(f"steps {c}: max |difference| {worst:.3g}")
        elif not x.equals(y):
            problems.append(f"steps {c}: values differ")
    return problems, len(common)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--tol", type=float, default=1e-9)
    args = parser.parse_args()
    failed = 0
    for summary in sorted(args.before.rglob("summary.json")):
        run = summary.parent.relative_to(args.before)
        other = args.after / run
        if not (other / "summary.json").exists():
            print(f"{run}: missing after")
            failed += 1
            continue
        problems = compare_summaries(
            json.loads(summary.read_text()), json.loads((other / "summary.json").read_text()), args.tol
        )
        steps, columns = compare_steps(
            pd.read_csv(summary.parent / "steps.csv"), pd.read_csv(other / "steps.csv"), args.tol
        )
        problems += steps
        print(
            f"{run}: {'equal' if not problems else f'{len(problems)} differences'} "
            f"({columns} step columns compared, tolerance {args.tol:g})"
        )
        for p in problems:
            print(f"    {p}")
        failed += bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
