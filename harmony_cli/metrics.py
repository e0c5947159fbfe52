"""Pure metric functions on the per-step table."""

from __future__ import annotations

import numpy as np
import pandas as pd


def time_stats_ms(values) -> dict[str, float]:
    """Median, p95 and max (and mean, never alone) of a series of times in ms."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"median": float("nan"), "p95": float("nan"), "max": float("nan"), "mean": float("nan")}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max()),
            "mean": float(v.mean())}


def tracking_error(steps: pd.DataFrame, hands: list[str]) -> dict[str, float]:
    """Max and RMS over time of the worse hand's position error [m]; worst rotation error [deg]."""
    err = steps[[f"{h}_error_m" for h in hands]].to_numpy().max(axis=1)
    rot = steps[[f"{h}_rot_error_deg" for h in hands]].to_numpy().max(axis=1)
    return {"max_m": float(err.max()), "rms_m": float(np.sqrt(np.mean(err**2))), "max_rot_deg": float(rot.max())}


def summarise(steps: pd.DataFrame, hands: list[str]) -> dict:
    return {
        "steps": int(len(steps)),
        "failed_solves": int((~steps["success"].astype(bool)).sum()),
        "held_last_plan": int(steps["held_last_plan"].astype(bool).sum()),
        "solve_time_ms": time_stats_ms(steps["solve_ms"]),
        "iterations_median": float(steps["iterations"].median()),
        "tracking_error": tracking_error(steps, hands),
    }


GOAL_TOLERANCE = 0.05  # [m] box centre from its goal
UPRIGHT_DEG = 10.0
REACHED = 0.03  # [m] both hands this close to their phase goal: the phase is complete


def task_outcome(steps: pd.DataFrame, scenario, hands: list[str]) -> dict:
    """Success (box on its goal within 5 cm, upright, never dropped), clearances, phase completion, loop time."""
    out: dict = {"loop_time_ms": time_stats_ms(steps["loop_ms"]),
                 "planner_time_ms": time_stats_ms(steps["planner_ms"].dropna()),
                 "planner_failures": int((steps["planner_success"].dropna() == False).sum())}  # noqa: E712
    yaw = steps[f"q_{scenario.robot.base_joints[2]}"]
    out["base_yaw_range_deg"] = float(np.degrees(yaw.max() - yaw.min()))
    clearances = {}
    for column in steps.columns:
        if column.startswith("clearance_"):
            _, who, *name, _ = column.split("_")
            clearances.setdefault("_".join(name), {})[who] = float(steps[column].min())
    out["min_clearance_m"] = clearances
    moving = [o.name for o in scenario.world.obstacles if o.motion is not None]
    out["min_clearance_moving_m"] = {name: clearances[name] for name in moving if name in clearances}
    phases = []
    goal_error = steps[[f"{h}_goal_error_m" for h in hands]].max(axis=1)
    for index, phase in enumerate(scenario.task.phases):
        rows = steps["phase_index"] == index
        reached = steps["t"][rows & (goal_error < REACHED + phase.squeeze / 2)]  # a squeeze goal is inside the box
        start = float(steps["t"][rows].min()) if rows.any() else None
        phases.append({"name": phase.name, "start_s": start,
                       "completed_s": float(reached.min()) if len(reached) else None,
                       "final_goal_error_m": float(goal_error[rows].iloc[-1]) if rows.any() else None})
    out["phases"] = phases
    clear = all(v > 0 for c in clearances.values() for v in c.values())
    solved = out["planner_failures"] == 0 and bool(steps["success"].astype(bool).all())
    out |= {"clear_of_obstacles": clear, "all_solves_succeeded": solved}
    box = scenario.world.box
    if box is None:  # success: every phase's goal reached, never touching an obstacle, no failed solve
        out["success"] = bool(clear and solved and all(p["completed_s"] is not None for p in phases))
    elif "box_x" in steps:
        final = steps[["box_x", "box_y", "box_z"]].iloc[-1].to_numpy()
        dropped = bool(steps["dropped"].any())
        error = float(np.linalg.norm(final - np.asarray(box.goal))) if box.goal else None
        upright = float(steps["box_tilt_deg"].iloc[-1]) < UPRIGHT_DEG
        out |= {"box_final": final.tolist(), "box_goal_error_m": error, "box_upright": upright,
                "box_dropped": dropped,
                "success": bool(error is not None and error <= GOAL_TOLERANCE and upright and not dropped and clear)}
    return out
