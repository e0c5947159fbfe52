"""Pure metric functions on the per-step table."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from harmony_cli.report.task_failure import GOAL_TOLERANCE, fell_at, task_failure
from harmony_cli.report.touches import touches
from harmony_cli.tasks.schedule import REACHED

if TYPE_CHECKING:
    from harmony_cli.scenario import PushSpec, Scenario


def time_stats_ms(values) -> dict[str, float]:
    """Median, p95 and max (and mean, never alone) of a series of times in ms."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"median": float("nan"), "p95": float("nan"), "max": float("nan"), "mean": float("nan")}
    return {
        "median": float(np.median(v)),
        "p95": float(np.percentile(v, 95)),
        "max": float(v.max()),
        "mean": float(v.mean()),
    }


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


UPRIGHT_DEG = 10.0


def task_outcome(steps: pd.DataFrame, scenario: Scenario, hands: list[str]) -> dict:
    """Success (box on its goal within 5 cm, upright, never dropped, no touch of a table or an obstacle: report/
    touches.py), clearances, phase completion and lateness, loop time."""
    out: dict = {
        "loop_time_ms": time_stats_ms(steps["loop_ms"]),
        "planner_time_ms": time_stats_ms(steps["planner_ms"].dropna()),
        "planner_failures": int((~steps["planner_success"].dropna().astype(bool)).sum()),
    }
    yaw = steps[f"q_{scenario.robot.base_joints[2]}"]
    out["base_yaw_range_deg"] = float(np.degrees(yaw.max() - yaw.min()))
    clearances: dict[str, dict[str, float]] = {}
    for column in steps.columns:
        if column.startswith("clearance_"):
            _, who, *name, _ = column.split("_")
            clearances.setdefault("_".join(name), {})[who] = float(steps[column].min())
    out["min_clearance_m"] = clearances
    moving = [o.name for o in scenario.world.obstacles if o.motion is not None]
    out["min_clearance_moving_m"] = {name: clearances[name] for name in moving if name in clearances}
    out["phases"] = phases = phase_outcomes(steps, scenario, hands)
    out["late_s"] = float(sum(p["late_s"] for p in phases))  # how far the waits moved the schedule
    out["timed_out_phases"] = [p["name"] for p in phases if p["timed_out"]]
    out["contacts"] = touches(steps, {t.name for t in scenario.world.tables})
    clear = all(v > 0 for c in clearances.values() for v in c.values())
    untouched = not out["contacts"]  # no contact with a table or an obstacle (a clearance <= 0 is one too)
    solved = out["planner_failures"] == 0 and bool(steps["success"].astype(bool).all())
    out |= {"clear_of_obstacles": clear, "contact_free": untouched, "all_solves_succeeded": solved}
    box = scenario.world.box
    completed = all(p["completed_s"] is not None for p in phases)  # every phase's goal reached
    if box is None:  # success: every phase's goal reached, never touching an obstacle, no failed solve
        out["success"] = bool(untouched and solved and completed and not out["timed_out_phases"])
    elif "box_x" in steps:
        final = steps[["box_x", "box_y", "box_z"]].iloc[-1].to_numpy()
        fell = fell_at(steps, [t.height for t in scenario.world.tables], box.size[2])
        dropped = bool(steps["dropped"].any()) or fell is not None  # out of the hands, or off the tables
        error = float(np.linalg.norm(final - np.asarray(box.goal))) if box.goal else None
        upright = float(steps["box_tilt_deg"].iloc[-1]) < UPRIGHT_DEG
        # a box with a goal must end there; one without (a lift) must have every phase's goal reached
        placed = error <= GOAL_TOLERANCE if error is not None else completed
        out |= {
            "grip_off_square_deg": first_held(steps, "box_off_square_deg"),
            "grip_shear_m": first_held(steps, "grip_shear_m"),
            "box_final": final.tolist(),
            "box_goal_error_m": error,
            "box_upright": upright,
            "box_dropped": dropped,
            "box_fell_s": fell,
            "success": bool(placed and upright and not dropped and untouched and not out["timed_out_phases"]),
        }
    if "success" in out:
        out["failure"] = task_failure(out, steps)
    return out


def phase_outcomes(steps: pd.DataFrame, scenario: Scenario, hands: list[str]) -> list[dict]:
    """Per task phase: `start_s`; `completed_s`, when its hands first reached its goal (None: never);
    `final_goal_error_m` at its last step; `waited_s`, how long it waited for its goal past its end as written
    (moved by the earlier phases' waits; tasks/schedule.py); `late_s`, how late it ended, which is that wait (a
    wait lasts until the goal is reached, at most the phase's own duration, twice that after its stance was
    re-planned); `replanned_s`, when it re-planned as it started to wait (planning/planner.py; None: it never
    waited, or waited with the box held); `restanced_s`, when it re-planned its stance as it would have given up
    (planning/planner.py; None: it did not);
    `timed_out`: it waited and its goal was still not reached at its last step (the next phase started without
    it): it stalled, and the run fails."""
    phases = []
    goal_error = steps[[f"{h}_goal_error_m" for h in hands]].max(axis=1)
    for index, phase in enumerate(scenario.task.phases if scenario.task else []):
        rows = steps["phase_index"] == index
        at_goal = rows & (goal_error < REACHED + phase.squeeze / 2)  # a squeeze goal is inside the box
        reached = steps["t"][at_goal]
        waited = float(np.ptp(steps["delay_s"][rows])) if rows.any() and "delay_s" in steps else 0.0
        replanned = rows & steps["replanned"].astype(bool) if "replanned" in steps else rows & False
        restanced = rows & steps["restanced"].astype(bool) if "restanced" in steps else rows & False
        phases.append(
            {
                "name": phase.name,
                "start_s": float(steps["t"][rows].min()) if rows.any() else None,
                "completed_s": float(reached.min()) if len(reached) else None,
                "final_goal_error_m": float(goal_error[rows].iloc[-1]) if rows.any() else None,
                "waited_s": waited,
                "late_s": waited,
                "replanned_s": float(steps["t"][replanned].min()) if replanned.any() else None,
                "restanced_s": float(steps["t"][restanced].min()) if restanced.any() else None,
                "timed_out": bool(waited > 0 and not at_goal[rows].iloc[-1]),
            }
        )
    return phases


def first_held(steps: pd.DataFrame, column: str) -> float | None:
    """A column's value when the box was first held (the lift's start: squeezed, not yet lifted): the grasp as
    made; None if it never was held (or the run logs no such column)."""
    held = steps["holding"].astype(bool) if "holding" in steps else pd.Series(False, index=steps.index)
    return float(steps[column][held].iloc[0]) if column in steps and held.any() else None


def force_outcome(steps: pd.DataFrame, hands: list[str]) -> dict | None:
    """Squeeze-force tracking (sensed pad normal force minus `{hand}_force_ref_N`) per phase and hand, over the
    phase's steps whose reference is > 0 (ramps included); None when the run logs no force reference."""
    if not all(f"{h}_force_ref_N" in steps for h in hands):
        return None
    phase = steps["phase"] if "phase" in steps else pd.Series("run", index=steps.index)

    def stats(rows) -> dict:
        per_hand = {}
        for h in hands:
            ref = steps[f"{h}_force_ref_N"]
            used = rows & (ref > 0)
            if used.any():
                error = (steps[f"{h}_force_normal_N"] - ref)[used].to_numpy()
                per_hand[h] = {
                    "rms_N": float(np.sqrt(np.mean(error**2))),
                    "max_N": float(np.abs(error).max()),
                    "bias_N": float(error.mean()),
                    "mean_ref_N": float(ref[used].mean()),
                    "steps": int(used.sum()),
                }
        return per_hand

    phases = {name: s for name in phase.unique() if (s := stats(phase == name))}
    overall = stats(pd.Series(True, index=steps.index))
    return {
        "phases_with_reference": list(phases),
        "phases": phases,
        "overall": overall,
        "rms_N": max((v["rms_N"] for v in overall.values()), default=None),  # the worse hand
        "max_N": max((v["max_N"] for v in overall.values()), default=None),
    }


RECOVERED_M = 0.01  # [m] a hand within this of its reference ...
RECOVERY_HOLD_S = 0.5  # ... for this long has recovered
AFTER_PUSH_S = 2.0  # [s] the push's window runs this long past its end


def recovery_time(
    t: np.ndarray, error: np.ndarray, t0: float, tol: float = RECOVERED_M, hold: float = RECOVERY_HOLD_S
) -> float | None:
    """Time from t0 until `error` is <= tol and stays there for >= hold (the log must cover it); None if never."""
    run_start = None
    for ti, e in zip(t, error):
        if ti < t0 - 1e-9:
            continue
        if not e <= tol:  # NaN (unknown) is not recovered
            run_start = None
            continue
        run_start = ti if run_start is None else run_start
        if ti - run_start >= hold - 1e-9:
            return float(run_start - t0)
    return None


def push_windows(push: PushSpec, after: float = AFTER_PUSH_S) -> tuple[tuple[float, float], tuple[float, float]]:
    """The baseline window just before a push and the push's own window [start, end + after), equally long."""
    length = push.duration + after
    return (max(0.0, push.start - length), push.start), (push.start, push.start + length)


def displacement_from_twin(steps: pd.DataFrame, twin: pd.DataFrame, hands: list[str]) -> pd.DataFrame:
    """`steps` with `{hand}_push_displacement_m`: each hand's distance from where it was at the same step of the
    push-free run of the same scenario (the loop is deterministic: exactly 0 before the first push; NaN past the
    push-free run's end)."""
    by_step = twin.set_index("step")
    columns = {}
    for h in hands:
        xyz = [f"{h}_meas_{a}" for a in "xyz"]
        other = by_step[xyz].reindex(steps["step"]).to_numpy()
        columns[f"{h}_push_displacement_m"] = np.linalg.norm(steps[xyz].to_numpy() - other, axis=1)
    return steps.assign(**columns)


def _window(steps: pd.DataFrame, hands: list[str], focus: list[str], start: float, end: float) -> dict:
    """Over [start, end), per hand: peak displacement (from the push-free run when known, else from the live
    reference), peak tracking error, peak sensed pad force (and the simulator's contact force); the recovery time of the
    focus hands (the worse of them) from `start`."""
    part = steps[(steps["t"] >= start - 1e-9) & (steps["t"] < end - 1e-9)]
    if part.empty:
        return {"window_s": [start, end], "steps": 0}
    twin = all(f"{h}_push_displacement_m" in part for h in hands)
    displacement = "_push_displacement_m" if twin else "_error_m"
    peak = lambda suffix: {h: float(part[h + suffix].max()) for h in hands}
    out = {
        "window_s": [start, end],
        "steps": int(len(part)),
        "displacement_from": "push-free run" if twin else "reference",
        "peak_displacement_m": peak(displacement),
        "peak_error_m": peak("_error_m"),
        "peak_pad_force_N": peak("_force_normal_N"),
    }
    if all(f"{h}_contact_N" in part for h in hands):
        out["peak_contact_N"] = peak("_contact_N")
    worst = part[[h + displacement for h in focus]].max(axis=1, skipna=False).to_numpy()
    out["recovery_s"] = recovery_time(part["t"].to_numpy(), worst, start)
    return out


def baseline_peak(outcome: dict, key: str) -> float | None:
    """The larger hand's value of `key` (e.g. peak_pad_force_N) in a push outcome's baseline window."""
    return max(outcome["baseline"].get(key, {}).values(), default=None)


def push_outcome(
    steps: pd.DataFrame, pushes, hands: list[str], pushed_hands: dict[str, str | None], after: float = AFTER_PUSH_S
) -> dict:
    """Per push, over its window [start, end + after): peak hand displacement (from the push-free run when
    `{hand}_push_displacement_m` is logged, else `{hand}_error_m`), peak sensed pad normal force (and
    the simulator's pad-box contact force when logged), recovery time of the pushed hand (the worse hand when the
    push is not on a hand); `baseline`: the same over the equally long window just before the push. Top-level
    numbers are the pushed (worse) hand's displacement and the larger pad force."""
    out = {}
    for push in pushes:
        hand = pushed_hands.get(push.name)
        focus = [hand] if hand else list(hands)
        (b0, b1), (p0, p1) = push_windows(push, after)
        during = _window(steps, hands, focus, p0, p1)
        baseline = _window(steps, hands, focus, b0, b1)
        applied = steps.get(f"push_{push.name}_N")
        dt = float(steps["t"].diff().median()) if len(steps) > 1 else 0.0
        peak = during.get("peak_displacement_m")
        out[push.name] = {
            "body": push.body,
            "link": push.link,
            "force_N": list(push.force),
            "start_s": push.start,
            "duration_s": push.duration,
            "pushed_hand": hand,
            "applied_impulse_N_s": None if applied is None else float(applied.sum() * dt),
            "peak_push_N": None
            if applied is None
            else float(applied[(steps["t"] >= p0 - 1e-9) & (steps["t"] < p1 - 1e-9)].max()),
            "peak_displacement_m": max(peak[h] for h in focus) if peak else None,
            "peak_pad_force_N": max(during["peak_pad_force_N"].values()) if peak else None,
            "peak_contact_N": max(during["peak_contact_N"].values()) if "peak_contact_N" in during else None,
            "recovery_s": during.get("recovery_s"),
            "push": during,
            "baseline": baseline,
        }
    return out
