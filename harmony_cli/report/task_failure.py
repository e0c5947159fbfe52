"""Why a task did not succeed: one category and a reason that says what, where and when, from a run's per-step
table and its task outcome (summary.json `task`), so nobody has to dig it out of steps.csv.

Categories, the first that applies: dropped (the box left the hands while held, or fell off the tables), collision
(the robot touched a table or an obstacle, or the box an obstacle: report/touches.py), box tipped, stalled (a
phase waited its whole wait for its goal and never reached it; one that waits with the box not held re-plans
once as it starts: tasks/schedule.py, planning/planner.py), box off goal, then (a task without a box: every
phase must reach its goal) phase timeout, and solver failures. A phase that stalled is named after an earlier
category's reason, as before or after it: a carry that waits in vain because the box fell earlier did not cause
the fall."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

FELL_BELOW = 0.05  # [m] a box whose centre sinks this far below resting on the lowest table top has fallen off
# A grasp named in a drop's reason: the box this far off square against the pads (held on its edges), or one pad
# this far ahead of the other across their axis (their squeeze a couple that turns the box). Clean grasps are well
# within both; sheared ones are many times beyond.
OFF_SQUARE_DEG = 0.5
SHEAR_M = 0.005
FRICTION_WINDOW_S = 1.5  # [s] before a drop (flagged once the contact has been lost for a moment; sim/contacts.py)
NORMAL_OFF_FACE_DEG = 5.0  # a contact normal further off the box's faces than this is said
SQUEEZE_OVER = 2.0  # a pad pressing more than this times its force reference before a drop is said
ARM_PRESS_N = 1.0  # [N] the box pressing on a robot link that is no pad with more than this is said


def fell_at(steps: pd.DataFrame, table_tops: list[float], box_height: float) -> float | None:
    """When the box fell off the tables to below the lowest one (None: it never did, or it did not start on a
    table). Held or not: a box on the floor is not where a task puts it."""
    if not table_tops or "box_z" not in steps:
        return None
    below = steps["box_z"].to_numpy() < min(table_tops) + box_height / 2 - FELL_BELOW
    if not below.any() or below[0]:
        return None
    return float(steps["t"].to_numpy()[np.argmax(below)])


def _first_time(steps: pd.DataFrame, rows: pd.Series) -> float | None:
    return float(steps["t"][rows].iloc[0]) if rows.any() else None


def _when(steps: pd.DataFrame, rows: pd.Series) -> str:
    first = steps[rows].iloc[0]
    phase = f" ({first['phase']})" if "phase" in steps else ""
    return f"t = {first['t']:.2f} s{phase}"


def _dropped(task: dict, steps: pd.DataFrame) -> str:
    """The drop (a held box out of contact for a moment) and the fall off the tables, in the order they came: a
    fall first (the drop is flagged only after the contact has been lost for a while) says the fall alone."""
    dropped = steps["dropped"].astype(bool)
    parts = []
    fell_s = task.get("box_fell_s")
    if dropped.any() and (fell_s is None or steps["t"][dropped].iloc[0] < fell_s):
        parts.append(f"the box left the hands at {_when(steps, dropped)}")
    if fell_s is not None:
        fell = steps["t"] == fell_s
        held = "while held" if "holding" in steps and bool(steps["holding"][fell].any()) else "while not held"
        subject = "it" if parts else "the box"
        parts.append(
            f"{subject} fell off the tables {held} at {_when(steps, fell)}, to z = {task['box_final'][2]:.2f} m"
        )
    off, shear = task.get("grip_off_square_deg"), task.get("grip_shear_m")
    grasp = []
    if off is not None and off > OFF_SQUARE_DEG:
        grasp.append(f"{off:.1f} deg off square against the pads (on its edges)")
    if shear is not None and shear > SHEAR_M:
        grasp.append(f"with one pad {1e3 * shear:.0f} mm ahead of the other")
    if parts and grasp:
        parts.append(f"it was gripped {' and '.join(grasp)}")
    drop_s = _dropped_s(task, steps)
    before = [_friction_before(steps, drop_s), _squeeze_before(steps, drop_s), _links_before(steps, drop_s)]
    return "; ".join(parts + [text for text in before if parts and text])


def _window(steps: pd.DataFrame, drop_s: float | None) -> pd.DataFrame | None:
    """The steps in the FRICTION_WINDOW_S before a drop (None: no drop)."""
    if drop_s is None:
        return None
    return steps[(steps["t"] >= drop_s - FRICTION_WINDOW_S) & (steps["t"] <= drop_s)]


def _squeeze_before(steps: pd.DataFrame, drop_s: float | None) -> str | None:
    """The pads' largest pressing force before a drop when it was over SQUEEZE_OVER times its reference (the hands
    crushing the box rather than holding it); None otherwise or without force columns."""
    before = _window(steps, drop_s)
    forces = [c for c in steps.columns if c.endswith("_force_normal_N")]
    references = [c for c in steps.columns if c.endswith("_force_ref_N")]
    if before is None or not forces or not references:
        return None
    pressed = float(np.nanmax(before[forces].to_numpy(float), initial=-np.inf))
    reference = float(np.nanmax(before[references].to_numpy(float), initial=-np.inf))
    if not np.isfinite(pressed) or reference <= 0 or pressed <= SQUEEZE_OVER * reference:
        return None
    return f"the pads pressed up to {pressed:.0f} N against a {reference:g} N reference"


def _links_before(steps: pd.DataFrame, drop_s: float | None) -> str | None:
    """The robot links other than the pads the box pressed on before a drop, and how hard; None if none."""
    before = _window(steps, drop_s)
    if before is None or "box_on_robot_N" not in steps:
        return None
    pressing = before[before["box_on_robot_N"] > ARM_PRESS_N]
    if pressing.empty:
        return None
    links = sorted({link for names in pressing["box_on_robot_links"].dropna() for link in str(names).split()})
    at = float(pressing["t"].iloc[0])
    return (
        f"the box pressed on the robot's {', '.join(links)} (up to {pressing['box_on_robot_N'].max():.0f} N) "
        f"from t = {at:.2f} s"
    )


def _friction_before(steps: pd.DataFrame, drop_s: float | None) -> str | None:
    """The pads' largest use of their friction in the moments before a drop and, when the simulator's contact normals
    lay off the box's faces then, how far (sim/contacts.py); None without contact columns."""
    used_columns = [c for c in steps.columns if c.endswith("_friction_used")]
    before = _window(steps, drop_s)
    if before is None or not used_columns:
        return None
    used = float(np.nanmax(before[used_columns].to_numpy(float), initial=-np.inf))
    if not np.isfinite(used):
        return None
    text = f"the pads used up to {100 * min(used, 1.0):.0f} % of their friction in the {FRICTION_WINDOW_S:g} s before"
    off_columns = [c for c in steps.columns if c.endswith("_contact_normal_off_face_deg")]
    off = float(np.nanmax(before[off_columns].to_numpy(float), initial=-np.inf))
    if off > NORMAL_OFF_FACE_DEG:
        text += f", the simulator's contact normals up to {off:.0f} deg off the box's faces"
    return text


def _dropped_s(task: dict, steps: pd.DataFrame) -> float | None:
    times = [_first_time(steps, steps["dropped"].astype(bool)), task.get("box_fell_s")]
    return min((t for t in times if t is not None), default=None)


def _touched(task: dict, steps: pd.DataFrame) -> tuple[str, str, float, pd.Series]:
    """(obstacle, robot or box, clearance [m], the steps it touched) of the smallest clearance of the run."""
    name, who, value = min(
        ((name, who, v) for name, c in task["min_clearance_m"].items() for who, v in c.items()), key=lambda n: n[2]
    )
    return name, who, value, steps[f"clearance_{who}_{name}_m"] <= 0


def _collision(task: dict, steps: pd.DataFrame) -> str:
    """Every touch of the run, the earliest first (report/touches.py); from the smallest clearance when the
    outcome lists no touches (written before contacts were read)."""
    if task.get("contacts"):
        return "; ".join(
            f"the {c['who']} touched {c['body']} at t = {c['first_s']:.2f} s"
            + (f" ({c['phase']})" if c.get("phase") else "")
            + f", {max(0.0, -1e3 * c['deepest_m']):.1f} mm deep at most, in {c['steps']} steps"
            for c in task["contacts"]
        )
    name, who, value, touching = _touched(task, steps)
    return f"the {who} touched obstacle {name} at {_when(steps, touching)} (clearance {value:.3f} m)"


def _collision_s(task: dict, steps: pd.DataFrame) -> float | None:
    if task.get("contacts"):
        return float(task["contacts"][0]["first_s"])
    return _first_time(steps, _touched(task, steps)[3])


def _collided(task: dict) -> bool:
    return task.get("clear_of_obstacles") is False or task.get("contact_free") is False


def _tipped(task: dict, steps: pd.DataFrame) -> str:
    return f"the box ended tilted {steps['box_tilt_deg'].iloc[-1]:.0f} deg"


def _timeout(task: dict, steps: pd.DataFrame) -> str:
    phase = next(p for p in task["phases"] if p.get("completed_s") is None)
    if phase.get("start_s") is None:
        return f"phase {phase['name']} never started (the run ended first)"
    away = f"the hands {phase['final_goal_error_m']:.2f} m from its goal"
    if "phase" in steps and steps["phase"].iloc[-1] == phase["name"]:
        return f"the run ended during phase {phase['name']} (t = {steps['t'].iloc[-1]:.2f} s), {away}"
    return f"phase {phase['name']} never reached its goal: {away} at its end"


def _stalled_phase(task: dict) -> tuple[int, dict]:
    return next((i, p) for i, p in enumerate(task["phases"]) if _gave_up(p))


def _stall(phase: dict) -> str:
    replanned, restanced = phase.get("replanned_s"), phase.get("restanced_s")
    again = f", re-planned at t = {replanned:.2f} s" if replanned is not None else ""
    again += f", its stance re-planned at t = {restanced:.2f} s" if restanced is not None else ""
    away = f"{phase['final_goal_error_m']:.2f} m" if phase.get("final_goal_error_m") is not None else "?"
    return (
        f"phase {phase['name']} stalled: its goal not reached after waiting {phase['waited_s']:.1f} s{again} "
        f"(the hands {away} from it)"
    )


def _stalled(task: dict, steps: pd.DataFrame) -> str:
    reason = _stall(_stalled_phase(task)[1])
    if task.get("box_goal_error_m") is not None:
        reason += f"; the box ended {100 * task['box_goal_error_m']:.1f} cm from its goal"
    return reason


def _stalled_s(task: dict, steps: pd.DataFrame) -> float | None:
    """When the stalled phase gave up: the next phase's start (None: the run ended in it)."""
    i, _ = _stalled_phase(task)
    phases = task["phases"]
    following = phases[i + 1].get("start_s") if i + 1 < len(phases) else None
    return float(following) if following is not None else None


def _off_goal(task: dict, steps: pd.DataFrame) -> str:
    return f"the box ended {100 * task['box_goal_error_m']:.1f} cm from its goal"


def _solves(task: dict, steps: pd.DataFrame) -> str:
    whole_body = int((~steps["success"].astype(bool)).sum())
    return f"{task.get('planner_failures', 0)} planner and {whole_body} whole-body MPC solves failed"


GOAL_TOLERANCE = 0.05  # [m] box centre from its goal: a box task with a goal succeeds only within it


def _off_goal_applies(task: dict) -> bool:
    error = task.get("box_goal_error_m")
    return error is not None and error > GOAL_TOLERANCE


Reason = Callable[[dict, pd.DataFrame], str]
When = Callable[[dict, pd.DataFrame], float | None]  # when it happened [s]; None: at the end of the run


def _at_end(task: dict, steps: pd.DataFrame) -> None:
    return None


# (category, applies to the task outcome, reason, when); the first that applies is the run's (box off goal is a
# box task's last criterion)
FAILURES: tuple[tuple[str, Callable[[dict], bool], Reason, When], ...] = (
    ("dropped", lambda t: t.get("box_dropped") is True, _dropped, _dropped_s),
    ("collision", _collided, _collision, _collision_s),
    ("box tipped", lambda t: t.get("box_upright") is False, _tipped, _at_end),
    ("stalled", lambda t: any(_gave_up(p) for p in t.get("phases", [])), _stalled, _stalled_s),
    ("box off goal", _off_goal_applies, _off_goal, _at_end),
    ("phase timeout", lambda t: any(p.get("completed_s") is None for p in t.get("phases", [])), _timeout, _at_end),
    ("solver failures", lambda t: t.get("all_solves_succeeded") is False, _solves, _at_end),
)


def _first(task: dict) -> tuple[str, Reason, When] | None:
    """The first failure that applies to a task outcome: (category, its reason, its time), or None."""
    return next(((name, reason, when) for name, applies, reason, when in FAILURES if applies(task)), None)


def failure_category(task: dict) -> str:
    """The category of an unsuccessful task outcome (also of a summary.json written before reasons existed)."""
    first = _first(task)
    return first[0] if first else "unsuccessful"


def task_failure(task: dict, steps: pd.DataFrame) -> dict | None:
    """{category, reason, at_s} of an unsuccessful task (None: it succeeded); at_s: when it happened (a drop's or a
    touch's first step), None when it is judged at the run's end."""
    if task.get("success"):
        return None
    first = _first(task)
    if first is None:
        return {
            "category": "unsuccessful",
            "reason": "no criterion of success failed that harmony knows of",
            "at_s": None,
        }
    category, reason, when = first
    at_s = when(task, steps)
    said = "" if category == "stalled" else _timed_out(task, steps, at_s)
    return {"category": category, "reason": reason(task, steps) + said, "at_s": at_s}


def _timed_out(task: dict, steps: pd.DataFrame, failed_s: float | None) -> str:
    """The first phase that stalled, and whether it gave up before or after the failure at `failed_s` (None: the
    end of the run), or ''. A phase gives up when the next one starts."""
    if not any(_gave_up(p) for p in task.get("phases", [])):
        return ""
    gave_up = _stalled_s(task, steps)
    gave_up = float(steps["t"].iloc[-1]) if gave_up is None else gave_up
    order = "before" if failed_s is None or gave_up <= failed_s else "after"
    return f"; {order} that, {_stall(_stalled_phase(task)[1])}"


def _gave_up(phase: dict) -> bool:
    """A phase that stalled: it waited and never reached its goal (`timed_out`; outcomes written before it:
    waited and never completed)."""
    if "timed_out" in phase:
        return bool(phase["timed_out"])
    return bool(phase.get("waited_s")) and phase.get("completed_s") is None
