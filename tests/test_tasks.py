"""The phase schedule: which phase runs when, its hand goals, and when the box is held."""

from __future__ import annotations

import numpy as np
import pytest

from harmony_cli.scenario import TaskSpec
from harmony_cli.tasks.schedule import Schedule

HANDS = ("left", "right")
STAY = {"left": None, "right": None}
TASK = TaskSpec.model_validate(
    {
        "phases": [
            {"name": "approach", "duration": 2.0, "hands": STAY},
            {"name": "squeeze", "duration": 1.5, "hands": STAY, "grasp": True},
            {"name": "carry", "duration": 3.0, "hands": STAY},
            {"name": "release", "duration": 1.0, "hands": STAY, "release": True},
            {"name": "retreat", "duration": 0.5, "hands": STAY},
        ]
    }
)
ENDS = np.cumsum([2.0, 1.5, 3.0, 1.0, 0.5])  # 2, 3.5, 6.5, 7.5, 8
HANDS_NOW = np.array([[0.5, 0.2, 1.0], [0.5, -0.2, 1.0]])


def _phase(**fields):
    return TaskSpec.model_validate({"phases": [{"name": "p", "duration": 1.0, **fields}]}).phases[0]


@pytest.mark.parametrize(
    ("t", "index"),
    [(0.0, 0), (1.999, 0), (2.0, 1), (3.4, 1), (3.5, 2), (6.5, 3), (7.5, 4), (7.99, 4), (8.0, 4), (100.0, 4)],
)
def test_phase_at_t_starts_where_the_previous_one_ends_and_the_last_is_held(t, index):
    schedule = Schedule(TASK, HANDS)
    active = schedule.at(t)
    assert active.index == index
    assert active.spec is TASK.phases[index]
    assert active.start == pytest.approx(ENDS[index - 1] if index else 0.0)
    assert active.end == pytest.approx(ENDS[index])
    assert schedule.duration == pytest.approx(8.0)


def test_absolute_goals_replace_the_hand_positions_and_null_keeps_them():
    schedule = Schedule(TASK, HANDS)
    phase = _phase(hands={"left": [1.0, 2.0, 3.0], "right": None})
    goal = schedule.goal(phase, HANDS_NOW, {})
    np.testing.assert_array_equal(goal, [[1.0, 2.0, 3.0], HANDS_NOW[1]])
    np.testing.assert_array_equal(schedule.goal(_phase(hands=STAY), HANDS_NOW, {}), HANDS_NOW)


def test_relative_goal_offsets_turn_with_the_object_s_yaw():
    schedule = Schedule(TASK, HANDS)
    phase = _phase(
        hands={
            "left": {"relative_to": "box", "offset": [1.0, 0.0, 0.0]},
            "right": {"relative_to": "box", "offset": [0.2, -0.3, 0.1]},
        }
    )
    box = np.array([2.0, 1.0, 0.9])
    goal = schedule.goal(phase, HANDS_NOW, {"box": (box, np.pi / 2)})
    np.testing.assert_allclose(goal[0], box + [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(goal[1], box + [0.3, 0.2, 0.1], atol=1e-12)
    unturned = schedule.goal(phase, HANDS_NOW, {"box": (box, 0.0)})
    np.testing.assert_allclose(unturned, box + np.array([[1.0, 0.0, 0.0], [0.2, -0.3, 0.1]]), atol=1e-12)


def test_squeeze_moves_the_two_goals_towards_each_other_by_the_squeeze_in_total():
    schedule = Schedule(TASK, HANDS)
    left, right = np.array([1.0, 0.4, 1.2]), np.array([1.3, -0.2, 1.0])
    plain = schedule.goal(_phase(hands={"left": list(left), "right": list(right)}), HANDS_NOW, {})
    squeezed = schedule.goal(_phase(hands={"left": list(left), "right": list(right)}, squeeze=0.05), HANDS_NOW, {})
    across = (right - left) / np.linalg.norm(right - left)
    np.testing.assert_allclose(squeezed[0], left + 0.025 * across, atol=1e-12)
    np.testing.assert_allclose(squeezed[1], right - 0.025 * across, atol=1e-12)
    assert np.linalg.norm(squeezed[1] - squeezed[0]) == pytest.approx(np.linalg.norm(right - left) - 0.05)
    np.testing.assert_allclose(plain, [left, right])


@pytest.mark.parametrize(
    ("t", "held"),
    [
        (0.0, False),
        (2.0, False),
        (3.49, False),
        (3.5, True),
        (5.0, True),
        (6.49, True),
        (6.5, False),
        (7.0, False),
        (8.0, False),
        (50.0, False),
    ],
)
def test_box_is_held_from_the_end_of_the_grasp_phase_until_a_release_phase_starts(t, held):
    assert Schedule(TASK, HANDS).holding(t) is held


def _waited(errors: list[float], dt: float = 0.1) -> Schedule:
    """The schedule after control steps of dt from t = 0 with the hands errors[k] from the goal at step k (the last
    value from then on), until t = 20 s."""
    schedule = Schedule(TASK, HANDS)
    for k in range(int(round(20 / dt))):
        schedule.wait(k * dt, dt, errors[min(k, len(errors) - 1)])
    return schedule


def test_a_phase_whose_goal_is_reached_in_time_never_waits():
    schedule = _waited([0.5] * 10 + [0.01])  # reached at t = 1.0 s, before approach ends at 2 s
    np.testing.assert_allclose(schedule.ends, ENDS)
    assert schedule.delay == 0.0


def test_a_lagging_phase_waits_until_its_goal_is_reached_and_every_later_phase_moves_with_it():
    schedule = _waited([0.5] * 26 + [0.01])  # approach reached at t = 2.6 s: it ends at 2.7 s instead of 2
    np.testing.assert_allclose(schedule.ends, ENDS + 0.7)
    assert schedule.at(2.69).spec.name == "approach" and schedule.at(2.71).spec.name == "squeeze"
    assert schedule.holding(ENDS[1] + 0.69) is False and schedule.holding(ENDS[1] + 0.71) is True


def test_a_phase_that_never_reaches_its_goal_waits_its_own_duration_once_then_the_next_ones_wait_in_turn():
    schedule = _waited([0.5])  # never reached: each phase but the last waits its own duration, up to t = 20 s
    np.testing.assert_allclose(schedule.waited[:2], [2.0, 1.5])
    assert schedule.ends[0] == pytest.approx(4.0) and schedule.waited[-1] == 0.0
