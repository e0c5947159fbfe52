"""Every unsuccessful task gets one category and a reason saying what, where and when (summary.json `task.failure`)."""

import pandas as pd

from harmony_cli.report.metrics import first_held
from harmony_cli.report.task_failure import fell_at, task_failure

TABLES = [1.015, 0.9]  # table top heights [m]
BOX = 0.3  # box height [m]


def _steps(box_z, holding, phase="carry", clearance=0.5):
    n = len(box_z)
    return pd.DataFrame(
        {
            "t": [0.02 * i for i in range(n)],
            "phase": [phase] * n,
            "holding": holding,
            "box_z": box_z,
            "dropped": [False] * n,
            "success": [True] * n,
            "clearance_robot_cylinder_m": [clearance] * n,
        }
    )


def test_a_box_that_falls_off_the_tables_is_found_when_it_sinks_below_the_lowest_top():
    """On a table at 1.015 m, then on the floor: fell at the first step below the lowest top (0.9 m) + half its
    height - 5 cm; a box that starts on the floor, or only sinks onto the lower table, never fell."""
    steps = _steps([1.165, 1.165, 1.05, 0.6, 0.15, 0.15], [False] * 6)
    assert fell_at(steps, TABLES, BOX) == steps["t"][3]
    assert fell_at(_steps([0.15] * 4, [False] * 4), TABLES, BOX) is None
    assert fell_at(_steps([1.165, 1.1, 1.05, 1.05], [False] * 4), TABLES, BOX) is None


def test_a_box_dropped_while_not_held_is_reported_as_dropped_with_when_and_where():
    steps = _steps([1.165, 1.165, 0.6, 0.15], [False] * 4, phase="release")
    task = {"success": False, "box_dropped": True, "box_fell_s": steps["t"][2], "box_final": [6.1, 3.3, 0.15]}
    failure = task_failure(task, steps)
    assert failure["category"] == "dropped"
    assert "while not held" in failure["reason"] and "t = 0.04 s (release)" in failure["reason"]
    assert failure["reason"].endswith("to z = 0.15 m") and "left the hands" not in failure["reason"]


def test_the_first_failure_that_applies_is_the_category_and_a_collision_names_its_obstacle():
    """A box off its goal after touching an obstacle is a collision (the earlier cause), named with its time."""
    steps = _steps([1.165] * 3, [True] * 3, clearance=-0.01)
    task = {
        "success": False,
        "box_dropped": False,
        "clear_of_obstacles": False,
        "min_clearance_m": {"cylinder": {"robot": -0.01}},
        "box_upright": True,
        "box_goal_error_m": 0.8,
    }
    failure = task_failure(task, steps)
    assert failure["category"] == "collision"
    assert "robot touched obstacle cylinder at t = 0.00 s (carry)" in failure["reason"]
    assert task_failure(task | {"success": True}, steps) is None


def test_a_phase_that_never_reached_its_goal_says_how_far_the_hands_were():
    steps = _steps([1.165] * 3, [True] * 3)
    phases = [{"name": "lift", "start_s": 0.0, "completed_s": 1.0, "final_goal_error_m": 0.01}]
    phases.append({"name": "carry", "start_s": 1.0, "completed_s": None, "final_goal_error_m": 1.234})
    task = {"success": False, "box_dropped": False, "clear_of_obstacles": True, "box_upright": True, "phases": phases}
    assert task_failure(task, steps) == {
        "category": "phase timeout",
        "reason": "the run ended during phase carry (t = 0.04 s), the hands 1.23 m from its goal",
        "at_s": None,
    }
    steps["phase"] = ["carry", "carry", "lower"]
    reason = task_failure(task, steps)["reason"]
    assert reason == "phase carry never reached its goal: the hands 1.23 m from its goal at its end"


def test_a_box_task_that_missed_a_phase_goal_and_its_box_goal_is_reported_off_goal_and_a_held_drop_first():
    """A box task's success is the box (dropped, clear, upright, at its goal): a phase that fell short of its
    goal is not the reason when the box is off goal; a box that left the hands and then fell says both."""
    steps = _steps([1.165, 1.165, 0.6, 0.15], [True] * 4)
    phases = [{"name": "approach", "start_s": 0.0, "completed_s": None, "final_goal_error_m": 0.06}]
    task = {"success": False, "clear_of_obstacles": True, "box_upright": True, "phases": phases}
    assert task_failure(task | {"box_dropped": False, "box_goal_error_m": 0.5}, steps)["category"] == "box off goal"
    steps.loc[1:, "dropped"] = True
    fell = task | {"box_dropped": True, "box_fell_s": steps["t"][2], "box_final": [3.0, 1.0, 0.15]}
    reason = task_failure(fell, steps)["reason"]
    assert reason.startswith("the box left the hands at t = 0.02 s (carry); it fell off the tables while held")
    # flagged as dropped only after the fall (contact lost for DROP_AFTER): the fall alone
    late = fell | {"box_fell_s": steps["t"][1]}
    assert task_failure(late, steps)["reason"].startswith("the box fell off the tables while held at t = 0.02 s")


def _waited_in_vain(goal_error: float) -> dict:
    """A task whose carry waited its whole 12 s for its goal (re-planned at 13 s), the box `goal_error` off."""
    phases = [{"name": "lift", "start_s": 0.0, "completed_s": 1.0, "final_goal_error_m": 0.01, "waited_s": 0.0}]
    phases.append(
        {"name": "carry", "start_s": 1.0, "completed_s": None, "final_goal_error_m": 0.43, "waited_s": 12.0}
        | {"replanned_s": 13.0, "timed_out": True}
    )
    task = {"success": False, "box_dropped": False, "clear_of_obstacles": True, "box_upright": True}
    return task | {"phases": phases, "box_goal_error_m": goal_error}


def test_a_phase_that_waited_for_its_goal_in_vain_stalls_the_run_and_the_reason_says_where_the_box_ended():
    failure = task_failure(_waited_in_vain(0.5), _steps([1.165] * 3, [True] * 3))
    assert failure["category"] == "stalled"
    assert failure["reason"] == (
        "phase carry stalled: its goal not reached after waiting 12.0 s, re-planned at t = 13.00 s (the hands "
        "0.43 m from it); the box ended 50.0 cm from its goal"
    )


def test_a_stalled_phase_fails_the_run_though_the_box_ended_on_its_goal():
    assert task_failure(_waited_in_vain(0.01), _steps([1.165] * 3, [True] * 3))["category"] == "stalled"


def test_a_phase_that_timed_out_after_the_drop_is_said_to_come_after_it():
    """The box fell 0.04 s into the carry; the carry waited in vain until the next phase at 13 s: after, not before."""
    steps = _steps([1.165, 1.165, 0.6, 0.15], [True] * 4)
    phases = [{"name": "carry", "start_s": 0.0, "completed_s": None, "final_goal_error_m": 0.5, "waited_s": 12.0}]
    phases.append({"name": "lower", "start_s": 13.0, "completed_s": None, "final_goal_error_m": 0.5, "waited_s": 0.0})
    task = {"success": False, "box_dropped": True, "box_fell_s": steps["t"][2], "box_final": [5.0, 2.0, 0.15]}
    reason = task_failure(task | {"phases": phases}, steps)["reason"]
    assert reason.startswith("the box fell off the tables while held at t = 0.04 s (carry)")
    assert "; after that, phase carry stalled" in reason and "before that" not in reason


def test_a_failure_says_when_it_happened_a_drop_at_its_first_step_an_off_goal_box_at_the_end():
    steps = _steps([1.165, 1.165, 0.6, 0.15], [True] * 4)
    fell = {"success": False, "box_dropped": True, "box_fell_s": steps["t"][2], "box_final": [5.0, 2.0, 0.15]}
    assert task_failure(fell, steps)["at_s"] == steps["t"][2]
    off = {"success": False, "box_dropped": False, "clear_of_obstacles": True, "box_upright": True}
    assert task_failure(off | {"box_goal_error_m": 0.5}, steps)["at_s"] is None


def test_a_drop_names_a_grasp_off_square_or_sheared_and_a_clean_grasp_adds_nothing():
    """The grasp as made (its values at the first held step) joins a drop's reason above 0.5 deg off square against
    the pads or 5 mm of shear."""
    steps = _steps([1.165, 1.165, 0.6, 0.15], [False, True, True, True])
    steps["box_off_square_deg"] = [7.0, 1.9, 3.0, 20.0]
    task = {"success": False, "box_dropped": True, "box_fell_s": steps["t"][2], "box_final": [3.0, 2.0, 0.15]}
    assert first_held(steps, "box_off_square_deg") == 1.9  # at the first held step, not before or after
    reason = task_failure(task | {"grip_off_square_deg": 1.9, "grip_shear_m": 0.012}, steps)["reason"]
    assert reason.endswith(
        "; it was gripped 1.9 deg off square against the pads (on its edges) and with one pad 12 mm ahead of the other"
    )
    reason = task_failure(task | {"grip_off_square_deg": 0.3, "grip_shear_m": 0.012}, steps)["reason"]
    assert reason.endswith("; it was gripped with one pad 12 mm ahead of the other")
    assert "gripped" not in task_failure(task | {"grip_off_square_deg": 0.05, "grip_shear_m": 0.001}, steps)["reason"]
    assert first_held(steps.assign(holding=False), "box_off_square_deg") is None


def test_a_drop_says_when_the_pads_crushed_the_box_and_what_else_of_the_robot_it_pressed_on():
    steps = _steps([1.3, 1.3, 1.3, 0.6, 0.15], [True] * 5)
    steps["left_force_normal_N"] = [20.0, 240.0, 90.0, 0.0, 0.0]
    steps["left_force_ref_N"] = [20.0] * 5
    steps["box_on_robot_N"] = [0.0, 0.0, 190.0, 40.0, 0.0]
    steps["box_on_robot_links"] = ["", "", "LARM2", "LARM2 CHEST", ""]
    task = {"success": False, "box_dropped": True, "box_fell_s": steps["t"][3], "box_final": [6.1, 3.3, 0.15]}
    reason = task_failure(task, steps)["reason"]
    assert "the pads pressed up to 240 N against a 20 N reference" in reason
    assert "the box pressed on the robot's CHEST, LARM2 (up to 190 N) from t = 0.04 s" in reason
    steps["left_force_normal_N"] = [20.0, 30.0, 20.0, 0.0, 0.0]  # within twice the reference: not said
    steps["box_on_robot_N"] = 0.0
    reason = task_failure(task, steps)["reason"]
    assert "pressed" not in reason


def test_a_box_on_its_goal_in_a_run_that_failed_otherwise_is_not_called_off_goal():
    """A box 1 cm from its goal (within the 5 cm it may be) in a run whose carry never reached its goal: the phase is
    the failure; a box 6 cm off is off goal."""
    steps = _steps([1.165] * 3, [True] * 3)
    phases = [{"name": "carry", "start_s": 0.0, "completed_s": None, "final_goal_error_m": 0.2}]
    task = {"success": False, "box_dropped": False, "clear_of_obstacles": True, "box_upright": True, "phases": phases}
    assert task_failure(task | {"box_goal_error_m": 0.01}, steps)["category"] == "phase timeout"
    assert task_failure(task | {"box_goal_error_m": 0.06}, steps)["category"] == "box off goal"
