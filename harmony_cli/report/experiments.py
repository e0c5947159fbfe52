"""The two-stage experiments' results table (Markdown, CSV) with each run's top-down plot and a video frame,
from run directories only."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from harmony_cli.provenance import Made, record
from harmony_cli.report.metrics import task_outcome
from harmony_cli.report.scene_plots import plot_top_down
from harmony_cli.scenario import load_scenario


def _row(run: Path) -> dict:
    """One run's outcomes, recomputed from its steps and resolved scenario (the metrics of this version)."""
    s = json.loads((run / "summary.json").read_text())
    scenario = load_scenario(run / "scenario.resolved.yaml", runnable=False)
    if scenario.task is None:
        return _tracking_row(s, scenario)
    task = task_outcome(pd.read_csv(run / "steps.csv"), scenario, list(scenario.robot.end_effectors))
    loop = task["loop_time_ms"]
    clearance = task.get("min_clearance_m", {})
    phases = task.get("phases", [])
    row = {
        "experiment": s["name"],
        "status": s["status"],
        "success": task.get("success"),
        "box goal error [cm]": None if task.get("box_goal_error_m") is None else 100 * task["box_goal_error_m"],
        "box dropped": task.get("box_dropped"),
        "box upright": task.get("box_upright"),
        "min clearance robot [m]": min((c["robot"] for c in clearance.values()), default=None),
        "min clearance box [m]": min((c["box"] for c in clearance.values() if "box" in c), default=None),
        "base yaw range [deg]": task.get("base_yaw_range_deg"),
        "loop median / p95 / max [ms]": f"{loop.get('median', float('nan')):.2f} / {loop.get('p95', float('nan')):.2f}"
        f" / {loop.get('max', float('nan')):.2f}",
        "planner failures": task.get("planner_failures"),
        "MPC failures": s.get("failed_solves"),
        "phases completed": f"{sum(p['completed_s'] is not None for p in phases)} / {len(phases)}",
        "steps": s.get("steps"),
    }
    moving = task.get("min_clearance_moving_m", {})
    for name, c in clearance.items():
        value = f"{c['robot']:.3f}, {c['box']:.3f}" if "box" in c else f"{c['robot']:.3f}"
        row[f"clearance {name} (robot, box) [m]"] = value + (" (moving)" if name in moving else "")
    return row


def _tracking_row(s: dict, scenario) -> dict:
    """A hand-trajectory run's row: the robot and its model's size, how closely the hands followed the reference,
    and the verdict against its tolerance (report/tracking.py)."""
    e, t, tracking = s.get("tracking_error", {}), s.get("solve_time_ms", {}), s.get("tracking", {})
    return {
        "experiment": s["name"],
        "status": s["status"],
        "robot": scenario.robot.preset or Path(scenario.robot.urdf).name,
        "joints (MPC)": s.get("n_dof"),
        "decision variables": s.get("decision_variables"),
        "max tracking error [cm]": None if "max_m" not in e else 100 * e["max_m"],
        "max rotation error [deg]": e.get("max_rot_deg"),
        "failed solves": f"{s.get('failed_solves')} / {s.get('steps')}",
        "solve median / p95 / max [ms]": f"{t.get('median', float('nan')):.2f} / {t.get('p95', float('nan')):.2f}"
        f" / {t.get('max', float('nan')):.2f}",
        "tracking": tracking.get("verdict", "-") if s["status"] == "completed" else "-",  # judged on a whole run
    }


def _frame(video: Path, target: Path, at: float = 0.5) -> Path | None:
    """The frame `at` (fraction) of the way through a video, as a PNG."""
    import imageio.v2 as imageio

    if not video.exists():
        return None
    reader = imageio.get_reader(video)
    try:
        n = reader.count_frames()  # type: ignore[attr-defined]  # the FFMPEG reader has it
        imageio.imwrite(target, reader.get_data(int(at * max(n - 1, 0))))
    finally:
        reader.close()
    return target


def experiments_report(dirs: list[Path], out: Path, name: str = "experiments") -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    frame = pd.DataFrame([_row(d) for d in dirs])
    written = [out / f"{name}.csv", out / f"{name}.md"]
    frame.to_csv(written[0], index=False)
    meta = json.loads((dirs[0] / "meta.json").read_text()) if dirs else {}
    items = frame.set_index("experiment").T
    fmt = lambda v: f"{v:.3f}" if isinstance(v, float) else str(v)
    markdown = (
        "| | "
        + " | ".join(items.columns)
        + " |\n|"
        + "---|" * (items.shape[1] + 1)
        + "\n"
        + "".join(f"| {item} | " + " | ".join(fmt(v) for v in row) + " |\n" for item, row in items.iterrows())
    )
    tasks = "success" in frame.columns  # a hand trajectory's row has a tracking verdict instead
    title, timed = (
        ("Two-stage experiments", "loop = planner + whole-body MPC, observation to command")
        if tasks
        else ("Hand-trajectory runs", "solve = the whole-body MPC's solver call")
    )
    written[1].write_text(
        f"# {title}\n\n{markdown}\nMeasured by harmony on {meta.get('cpu', '?')}, one run at a time; {timed}.\n"
    )
    for d in dirs:
        scenario = load_scenario(d / "scenario.resolved.yaml", runnable=False)
        plot_top_down(
            out,
            pd.read_csv(d / "steps.csv"),
            scenario,
            list(scenario.robot.end_effectors),
            name=f"{scenario.name}_top_down.png",
        )
        written.append(out / f"{scenario.name}_top_down.png")
        label = scenario.name
        still = _frame(d / "video.mp4", out / f"{label}_frame.png")
        if still:
            written.append(still)
    record(written, Made.from_runs(dirs))
    return written
