"""A study's results as data: one row per run, read back from its run directory (its summary.json is the record),
written to Parquet for pandas or DuckDB."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pandas as pd

from harmony_cli.report.summary import task_warning
from harmony_cli.report.task_failure import failure_category
from harmony_cli.study.plan import PlannedRun

TABLE = "study.parquet"
NOT_RUN = ("interrupted", "killed", "running", "not run")  # statuses that are no result (the run did not end)
# a run cut off (its driver died) or a directory without a whole summary: no result, and run again when the study is
INCOMPLETE = ("killed", "running")
# Outcomes of a run that ended before the robot moved: a proof from geometry that the scene has no solution (not a
# draw of the controller's: out of the denominator), or the controller's stance search finding none (its failure)
IMPOSSIBLE, NO_STANCE = "impossible", "no stance"
SUCCESS, SUCCESS_LATE = "success", "success, a phase late"  # both successes; the second counted apart


def _failed_first(summary: dict) -> dict | None:
    """The task's failure of a run that stopped after it had happened (a drop, a touch, at its time): the cause,
    where the stop (the planner failing for a second once the box is on the floor) is its consequence."""
    failure = (summary.get("task") or {}).get("failure") or {}
    return failure if summary.get("status") == "failed" and failure.get("at_s") is not None else None


def outcome(summary: dict) -> str:
    """success (or success with a phase that ended late: it waited for its goal and reached it) | a task failure
    (dropped, collision, stalled, ...) | impossible | no stance | `run failed: <category>` (timeout, worker_lost,
    ...) | interrupted | incomplete | not run."""
    status = summary.get("status", "not run")
    if status in NOT_RUN:
        return "incomplete" if status in INCOMPLETE else status
    if first := _failed_first(summary):
        return first["category"]
    if status != "completed":
        failure = summary.get("failure", "error")
        return failure if failure in (IMPOSSIBLE, NO_STANCE) else f"run failed: {failure}"
    task = summary.get("task")
    if task is None:  # a hand trajectory: success is every solve succeeding
        return SUCCESS if summary.get("failed_solves") == 0 else "solver failures"
    if task.get("success"):
        return SUCCESS_LATE if task.get("late_s") else SUCCESS
    return (task.get("failure") or {}).get("category") or failure_category(task)  # older runs: no failure


def flatten(value: Any, prefix: str) -> dict[str, Any]:
    """Scalars of a summary under dotted names: dicts by key, lists of named dicts by name, other lists by index."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in flatten(item, f"{prefix}.{key}").items()}
    if isinstance(value, list):
        named = all(isinstance(i, dict) and "name" in i for i in value) and value
        return {
            k: v
            for n, item in enumerate(value)
            for k, v in flatten(
                {a: b for a, b in item.items() if a != "name"} if named else item,
                f"{prefix}.{item['name'] if named else n}",
            ).items()
        }
    return {prefix: value}


def run_row(run: PlannedRun, run_dir: Path) -> dict[str, Any]:
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        summary = {"status": "not run" if not run_dir.is_dir() else "killed"}
    result = outcome(summary)
    row: dict[str, Any] = {
        "draws": run.sample.draws,
        "seed": run.sample.seed,
        "sample": run.sample.index,
        "point": run.label,
        "key": run.key,
        "run_dir": str(run_dir),
        "status": summary.get("status"),
        "failure": summary.get("failure"),
        "outcome": result,
        "success": result in (SUCCESS, SUCCESS_LATE) if summary.get("status") not in NOT_RUN else None,
        "reason": run_reason(summary),
        "resamples": len(run.sample.rejected),
        "rejected": list(run.sample.rejected),  # why each earlier draw of the sample was refused
    }
    row |= {f"grid.{k}": v for k, v in run.point.values.items()}
    row |= flatten(run.sample.values, "vary") | flatten(run.scene, "scene")
    row |= {k: v for k, v in flatten(summary, "summary").items() if k not in ("summary.status", "summary.reason")}
    return row


def write_table(rows: list[dict[str, Any]], path: Path) -> pd.DataFrame:
    """The rows as a Parquet file (written whole, then renamed: a reader never sees half a file)."""
    table = pd.DataFrame(rows)
    for column in table.columns:  # a column Parquet cannot type (e.g. numbers and text) is kept as text
        kinds = {type(v) for v in table[column] if v is not None and v == v}
        if (len(kinds) > 1 and kinds - {int, float, bool}) or kinds & {list, dict}:
            table[column] = table[column].map(lambda v: None if v is None else json.dumps(v))
    part = path.with_suffix(".parquet.part")
    table.to_parquet(part, index=False)
    os.replace(part, path)
    return table


def run_reason(summary: dict) -> str | None:
    """Why a run did not succeed (the run's fault, or its task's failure), with the written task's warnings when
    there is one (what to change first); None when it succeeded."""
    reason = summary.get("reason") or summary.get("error")
    if (first := _failed_first(summary)) and reason:
        reason = f"{first['reason']}; then the run stopped: {reason}"
    reason = reason or ((summary.get("task") or {}).get("failure") or {}).get("reason")
    if reason and (written := task_warning(summary)):
        return f"{reason}; {written}"
    return reason
