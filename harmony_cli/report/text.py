"""Results as text: number and cell formatting the tables share, and the lines `harmony run` prints for a run."""

from __future__ import annotations

from pathlib import Path

from harmony_cli.report.metrics import baseline_peak
from harmony_cli.report.summary import task_warning
from harmony_cli.report.tracking import tracking_failed


def markdown_cell(text, width: int = 160) -> str:
    """A value as one Markdown table cell: no pipes, no line breaks, at most `width` characters ("" for none)."""
    return "" if text is None or text != text else str(text).replace("|", "/").replace("\n", " ")[:width]


def fmt(v: float | None, unit: str, scale: float = 1.0, missing: str = "-", digits: int = 2) -> str:
    return missing if v is None else f"{scale * v:.{digits}f} {unit}"


def run_lines(run_dir: Path, summary: dict) -> list[str]:
    """The run's status, solve times and tracking; the task's outcome; force and push responses; the video."""
    t, e = summary["solve_time_ms"], summary["tracking_error"]
    lines = [
        f"{run_dir}: {summary['status']}, {summary['decision_variables']} decision variables, "
        f"solve median {t['median']:.2f} / p95 {t['p95']:.2f} / max {t['max']:.2f} ms, "
        f"max tracking error {100 * e['max_m']:.2f} cm, failed solves {summary['failed_solves']}"
    ]
    if "task" in summary:
        task, loop = summary["task"], summary["task"]["loop_time_ms"]
        clear = min((v for c in task["min_clearance_m"].values() for v in c.values()), default=None)
        lines.append(
            f"task: success {task.get('success')}, box goal error {fmt(task.get('box_goal_error_m'), 'cm', 100)}, "
            f"dropped {task.get('box_dropped')}, min clearance {fmt(clear, 'm', missing='- (no obstacle)', digits=3)}"
            f", loop median {loop['median']:.2f} / "
            f"p95 {loop['p95']:.2f} / max {loop['max']:.2f} ms, planner failures {task['planner_failures']}"
        )
        if task.get("failure"):
            lines.append(f"task failed ({task['failure']['category']}): {task['failure']['reason']}")
        if written := task_warning(summary):
            lines.append(f"warning: {written}")
        for name, c in task.get("min_clearance_moving_m", {}).items():
            clearances = ", ".join(f"{who} {v:.3f} m" for who, v in c.items())
            lines.append(f"moving obstacle {name}: min clearance {clearances}")
    if tracking_failed(summary):
        lines.append(f"tracking failed: {summary['tracking']['reason']}")
    lines += disturbance_lines(summary.get("task", summary))
    if "video" in summary:
        lines.append(f"video: {summary['video']}")
    return lines


def disturbance_lines(outcome: dict) -> list[str]:
    """Squeeze-force tracking and each push's response, one line each (nothing when neither was measured)."""
    lines = []
    if force := outcome.get("force"):
        lines.append(
            f"squeeze force error (worse hand, reference > 0): RMS {fmt(force['rms_N'], 'N')}, max "
            f"{fmt(force['max_N'], 'N')}; phases: {', '.join(force['phases_with_reference'])}"
        )
    for name, p in outcome.get("pushes", {}).items():
        recovery = "never" if p["recovery_s"] is None else f"{p['recovery_s']:.2f} s"
        lines.append(
            f"push {name} on {p['pushed_hand'] or p['body']} (displacement from the "
            f"{p['push'].get('displacement_from')}): peak displacement "
            f"{fmt(p['peak_displacement_m'], 'cm', 100)} (baseline "
            f"{fmt(baseline_peak(p, 'peak_displacement_m'), 'cm', 100)}), peak pad force "
            f"{fmt(p['peak_pad_force_N'], 'N')} (baseline {fmt(baseline_peak(p, 'peak_pad_force_N'), 'N')}), "
            f"back within 1 cm for 0.5 s after {recovery}, peak pusher force "
            f"{fmt(p.get('peak_push_N'), 'N')}"
        )
    return lines
