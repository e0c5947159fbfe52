"""A run's summary.json metrics from its per-step table: solve times and tracking, the task's outcome, and the
squeeze-force and push responses beside it."""

from __future__ import annotations

import pandas as pd

from harmony_cli.report.metrics import force_outcome, push_outcome, summarise, task_outcome
from harmony_cli.report.tracking import tracking_verdict
from harmony_cli.scenario import Scenario


def summarise_run(
    steps: pd.DataFrame, scenario: Scenario, hands: list[str], pushed_hands: dict[str, str | None]
) -> dict:
    """The metrics to merge into summary.json; force and push metrics sit in `task` for a task scenario, at the
    top level otherwise. `pushed_hands`: push name -> the hand it acts on (None: not on a hand)."""
    summary = summarise(steps, hands)
    if scenario.task is not None:
        summary["task"] = task_outcome(steps, scenario, hands)
    if scenario.reference is not None and len(steps):
        verdict = tracking_verdict(steps, hands, scenario.reference.tolerance, scenario.sim.control_dt)
        summary["tracking"] = verdict.as_dict()
    outcome = summary.get("task", summary)
    if (force := force_outcome(steps, hands)) is not None:
        outcome["force"] = force
    if scenario.pushes:
        outcome["pushes"] = push_outcome(steps, scenario.pushes, hands, pushed_hands)
    return summary


def task_warning(summary: dict) -> str | None:
    """The written task's warnings of a summary.json (`stance_warning` in runs before the reach was checked)."""
    return summary.get("task_warning") or summary.get("stance_warning")
