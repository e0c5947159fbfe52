"""A phase that waited for its goal past its end (tasks/schedule.py) is reported late by its wait, and timed out when
its goal was still not reached as the next phase started (report/metrics.py `phase_outcomes`), on synthetic steps
tables of the smoke scenario's phases (raise 3 s, approach 4 s, ...); in a closed-loop run, a phase that starts
waiting re-plans once and presses its goal harder, and one that waits in vain stalls the run."""

import json

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.report.metrics import phase_outcomes
from harmony_cli.scenario import load_scenario
from harmony_cli.tasks.schedule import Schedule

DT = 0.1
HANDS = ["left", "right"]


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(ROOT / "scenarios" / "smoke" / "box_lift.yaml")


def _steps(*phases: tuple[np.ndarray, np.ndarray]) -> pd.DataFrame:
    """Phases back to back, each as (its rows' delay_s, its rows' goal error [m], both hands alike)."""
    index = np.concatenate([np.full(len(delay), i) for i, (delay, _) in enumerate(phases)])
    error = np.concatenate([e for _, e in phases])
    return pd.DataFrame(
        {
            "t": DT * np.arange(len(index)),
            "phase_index": index,
            "delay_s": np.concatenate([d for d, _ in phases]),
            "left_goal_error_m": error,
            "right_goal_error_m": error,
        }
    )


def _on_time(seconds: float, delay: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A phase that reaches its goal at its end without waiting."""
    n = round(seconds / DT)
    return np.full(n, delay), np.linspace(0.3, 0.01, n)


def _waiting(seconds: float, waited: float, error: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A phase that runs its written `seconds`, then waits `waited` more (the delay grows a step at a time)."""
    n, extra = round(seconds / DT), round(waited / DT)
    return np.concatenate([np.zeros(n - 1), DT * np.arange(extra + 1)]), error[: n + extra]


def test_a_phase_that_waited_and_never_reached_its_goal_timed_out_late_by_its_whole_wait(scenario):
    """Approach (4 s) waits its whole duration, the hands 0.2 m off: late 4 s, timed out."""
    steps = _steps(_on_time(3.0), _waiting(4.0, 4.0, np.full(80, 0.2)), _on_time(3.0, delay=4.0))
    raised, approach, close = phase_outcomes(steps, scenario, HANDS)[:3]
    assert approach["timed_out"] and approach["late_s"] == pytest.approx(4.0)
    assert approach["completed_s"] is None
    assert not raised["timed_out"] and raised["late_s"] == 0.0
    assert not close["timed_out"] and close["late_s"] == 0.0  # moved by the wait, but on time


def test_a_phase_that_waited_then_reached_its_goal_is_late_by_its_wait_and_not_timed_out(scenario):
    """Approach reaches its goal 1.5 s into its wait: late 1.5 s, completed at that step."""
    error = np.concatenate([np.full(54, 0.2), np.full(1, 0.01)])  # 4 s as written, then 1.5 s of waiting
    steps = _steps(_on_time(3.0), _waiting(4.0, 1.5, error), _on_time(3.0, delay=1.5))
    approach = phase_outcomes(steps, scenario, HANDS)[1]
    assert approach["late_s"] == pytest.approx(1.5) and not approach["timed_out"]
    assert approach["completed_s"] == pytest.approx(steps["t"][steps["phase_index"] == 1].iloc[-1])


def test_a_phase_that_reached_its_goal_early_but_waited_in_vain_at_its_end_timed_out(scenario):
    """The goal touched mid-phase and lost again: what counts is the goal at the step the phase gave up."""
    error = np.full(80, 0.2)
    error[20] = 0.01
    steps = _steps(_on_time(3.0), _waiting(4.0, 4.0, error))
    approach = phase_outcomes(steps, scenario, HANDS)[1]
    assert approach["completed_s"] is not None and approach["timed_out"] and approach["late_s"] == pytest.approx(4.0)


@pytest.fixture(scope="module")
def out_of_reach(tmp_path_factory) -> tuple[pd.DataFrame, dict]:
    """A closed-loop box_lift whose raise asks the hands 2.4 m apart, wider than the arms spread: it waits its 3 s
    in vain. Its steps table and its summary's task section."""
    wide = [f"task.phases.raise.hands.{h}=[0.76, {y}, 1.245]" for h, y in (("left", 1.2), ("right", -1.2))]
    sets = [arg for o in [*wide, "sim.duration=4.0"] for arg in ("--set", o)]
    out = tmp_path_factory.mktemp("late") / "run"
    result = CliRunner().invoke(
        app, ["run", str(ROOT / "scenarios" / "smoke" / "box_lift.yaml"), "--out", str(out), "--quiet", *sets]
    )
    assert result.exit_code == 1, result.output  # the task fails (its raise stalls): harmony run says so
    return pd.read_csv(out / "steps.csv"), json.loads((out / "summary.json").read_text())["task"]


def test_a_phase_sent_out_of_reach_re_plans_once_as_it_starts_waiting_and_then_stalls_the_run(out_of_reach):
    steps, task = out_of_reach
    replanned = steps[steps["replanned"].astype(bool)]
    assert list(replanned["phase"]) == ["raise"]  # once, in the phase that waited
    assert replanned["t"].iloc[0] == steps["t"][steps["delay_s"] > 0].iloc[0]  # as it started to wait
    assert task["success"] is False and task["failure"]["category"] == "stalled"


def test_a_waiting_phase_presses_its_goal_harder_from_its_wait_s_first_second_on(out_of_reach, scenario):
    """The hands' tracking weight is 1 until the phase waits, then ramps up to mpc.weights.late_task within a
    second, and the next phase starts at 1 again."""
    steps, _ = out_of_reach
    raise_ = steps[steps["phase"] == "raise"]
    waiting = raise_[raise_["delay_s"] > 0]
    assert (raise_["task_weight"][raise_["delay_s"] == 0] == 1.0).all()
    pressed = waiting[waiting["delay_s"] >= 1.0]
    assert (pressed["task_weight"] == scenario.mpc.weights.late_task).all() and len(pressed) > 0
    assert waiting["task_weight"].is_monotonic_increasing and waiting["task_weight"].iloc[0] > 1.0
    assert (steps["task_weight"][steps["phase"] == "approach"] == 1.0).all()


def _stalls(scenario, retried: bool) -> tuple[list[float], float]:
    """box_lift's schedule stepped with the hands never at any goal: when its first phase (raise, 3 s) stalled
    (the step its wait ran out at), retried once at its first stall when `retried`, and how long it waited."""
    schedule, dt, times = Schedule(scenario.task, tuple(HANDS)), 0.02, []
    for step in range(round(15.0 / dt)):
        t = step * dt
        if schedule.stalled(t, dt, 0.2) == 0:
            times.append(t)
            if retried and len(times) == 1:
                schedule.retry(0)
        schedule.wait(t, dt, 0.2)
    return times, float(schedule.waited[0])


def test_a_stalled_phase_retried_once_waits_its_duration_again_and_then_stalls_for_good(scenario):
    once, waited_once = _stalls(scenario, retried=False)
    twice, waited_twice = _stalls(scenario, retried=True)
    assert once == pytest.approx([6.0], abs=0.03) and waited_once == pytest.approx(3.0)
    assert twice == pytest.approx([6.0, 9.0], abs=0.03) and waited_twice == pytest.approx(6.0)
