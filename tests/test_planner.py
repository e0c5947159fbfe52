"""The task-space planner (MPC-T): both hands from their measured state to the phase goal at rest."""

from __future__ import annotations

import numpy as np
import pytest

from harmony_cli.maths.bezier import difference_matrix, evaluate
from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Obstacle
from harmony_cli.planning.hand_sqp import rate_bounds
from harmony_cli.planning.plan_horizon import least_horizon, meets, retimed
from harmony_cli.scenario import PlannerSpec

SPEC = PlannerSpec(step_iterations=PlannerSpec().phase_iterations)  # first plans in one step: test_first_plan.py
HOME = np.stack([np.eye(3), np.eye(3)])
OFFSET = np.pi / 2  # hand 0 at +y, hand 1 at -y: heading 0 faces +x
START = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
GOAL = START + [2.0, 0.0, 0.0]
PHASE_END = 5.0
CLEARANCE, CARRYING = 0.13, 0.2


def _cylinder(y: float) -> Obstacle:
    return Obstacle(Shape("cylinder", np.array([1.7, y, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), CLEARANCE)


def _plan(obstacles=(), goal=GOAL, phase_end=PHASE_END, carrying=None, drop=0.0, ceiling=None):
    planner = HandMPC(SPEC, list(obstacles), HOME, OFFSET, ceiling=ceiling)
    args = (HandState(START, np.zeros((2, 3)), 0.0), goal, phase_end, 0, carrying, drop)
    result = planner.step(0.0, *args)
    if planner.awaiting is not None:  # the phase's first plan wants a route: the next step tries it
        result = planner.step(0.0, *args)
    return planner, result


def _headings(rotations: np.ndarray) -> np.ndarray:
    """Heading of hand 0 (home rotations are the identity, so R = Rz(heading))."""
    return np.arctan2(rotations[:, 0, 1, 0], rotations[:, 0, 0, 0])


def _speed_limits() -> np.ndarray:
    return np.r_[SPEC.max_speed, SPEC.max_speed, SPEC.max_yaw_rate]


def test_free_space_plan_starts_at_the_hands_and_ends_at_rest_at_the_goal_within_the_speed_bounds():
    _, result = _plan()
    assert result.success
    plan = result.plan
    C, T = plan.control_points, plan.horizon
    assert plan.start == 0.0 and T == PHASE_END
    positions, rotations = plan.sample(np.array([0.0, PHASE_END]))
    np.testing.assert_allclose(positions[0], START, atol=1e-12)
    np.testing.assert_allclose(positions[1], GOAL, atol=1e-9)
    np.testing.assert_allclose(_headings(rotations), 0.0, atol=1e-9)
    for order in (1, 2):
        np.testing.assert_allclose(evaluate(C, [1.0], order, T), 0.0, atol=1e-6)
    hodograph = C @ difference_matrix(C.shape[1], 1, T).T  # bounds every velocity of the curve
    assert np.all(np.abs(hodograph) <= _speed_limits()[:, None] + 1e-6)


def test_free_space_plan_keeps_the_hands_level_and_across_the_heading():
    _, result = _plan()
    positions, rotations = result.plan.sample(np.linspace(0.0, PHASE_END, 50))
    np.testing.assert_allclose(positions[:, 0, 2], positions[:, 1, 2], atol=1e-3)
    across = positions[:, 1, :2] - positions[:, 0, :2]
    psi = _headings(rotations)
    heading = np.stack([np.cos(psi), np.sin(psi)], axis=1)
    np.testing.assert_allclose(np.sum(across * heading, axis=1), 0.0, atol=1e-3)


def _clearances(plan, obstacle: Obstacle, samples: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed distance minus the required clearance of hand 0, hand 1 and the carried object (midpoint)."""
    positions, _ = plan.sample(np.linspace(plan.start, plan.start + plan.horizon, samples))
    distance = obstacle.shape.distance
    return (
        distance(positions[:, 0])[0] - obstacle.clearance,
        distance(positions[:, 1])[0] - obstacle.clearance,
        distance(positions.mean(axis=1))[0] - obstacle.clearance - CARRYING,
    )


def _assert_plan_goes_around(obstacle: Obstacle):
    straight = START + np.linspace(0.0, 1.0, 200)[:, None, None] * (GOAL - START)
    assert np.min(obstacle.shape.distance(straight.mean(axis=1))[0]) < obstacle.clearance + CARRYING  # premise
    assert np.min(obstacle.shape.distance(straight.reshape(-1, 3))[0]) < obstacle.clearance  # premise
    _, result = _plan([obstacle], carrying=CARRYING)
    assert result.success
    for margin in _clearances(result.plan, obstacle):
        assert np.min(margin) >= -5e-3


def test_carrying_plan_keeps_hands_and_object_clear_of_a_cylinder_on_the_straight_path():
    _assert_plan_goes_around(_cylinder(0.0))


def test_carrying_plan_keeps_hands_and_object_clear_of_a_cylinder_beside_the_straight_path():
    _assert_plan_goes_around(_cylinder(-0.2))


def test_carrying_plan_keeps_the_grip_width_around_a_cylinder_near_the_straight_path():
    _, result = _plan([_cylinder(0.05)], carrying=CARRYING)
    positions, _ = result.plan.sample(np.linspace(0.0, PHASE_END, 200))
    width = np.linalg.norm(positions[:, 1] - positions[:, 0], axis=1)
    np.testing.assert_allclose(width, np.linalg.norm(START[1] - START[0]), atol=0.02)


def test_carrying_plan_passes_two_cylinders_on_either_side_of_the_straight_path_with_the_hands_together():
    first, second = (
        Obstacle(Shape("cylinder", np.array([x, y, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), CLEARANCE)
        for x, y in ((1.6, 0.1), (2.7, -0.1))
    )
    _, result = _plan([first, second], goal=START + [3.0, 0.0, 0.0], phase_end=7.0, carrying=CARRYING)
    assert result.success and result.routed
    for obstacle in (first, second):
        for margin in _clearances(result.plan, obstacle):
            assert np.min(margin) >= -1e-2  # the planner's 20 samples are 15 cm apart on this path: it dips between
    positions, _ = result.plan.sample(np.linspace(0.0, result.plan.horizon, 200))
    width = np.linalg.norm(positions[:, 1] - positions[:, 0], axis=1)
    np.testing.assert_allclose(width, np.linalg.norm(START[1] - START[0]), atol=0.02)


def test_a_carried_box_the_hands_cannot_lift_over_a_crate_goes_round_it_below_the_ceiling():
    crate = Obstacle(Shape("box", np.array([1.7, 0.0, 0.39]), 0.0, np.array([0.2, 0.2, 0.39])), CLEARANCE)
    drop, ceiling = 0.3, START[0, 2] + 0.02  # the box's bottom 0.3 m below the hands: 0.15 m below the crate's top
    over = _plan([crate], carrying=CARRYING, drop=drop)[1].plan.sample(np.linspace(0.0, PHASE_END, 200))[0]
    assert over[:, :, 2].max() > ceiling + 0.05  # premise: without a ceiling the plan lifts the box over the crate
    _, result = _plan([crate], carrying=CARRYING, drop=drop, ceiling=ceiling)
    positions, _ = result.plan.sample(np.linspace(0.0, PHASE_END, 200))
    assert result.success and positions[:, :, 2].max() <= ceiling + 1e-9
    bottom = positions.mean(axis=1) - [0.0, 0.0, drop]
    # round it, not through it (the planner checks 20 samples, 10 cm apart on this path: it dips between them)
    assert crate.shape.grown(CARRYING).distance(bottom)[0].min() >= CLEARANCE - 3e-2


@pytest.mark.parametrize("yaw_deg", [90.0, -135.0])
def test_a_scene_turned_about_z_gives_the_plan_turned_the_same_whatever_the_robot_s_home_yaw(yaw_deg):
    # the robot's home (hence its hand frames and the heading offset) turned with the scene: the plan must turn
    # with it; the facing term once assumed a home facing +x and twisted a turned robot's heading by ~55 deg
    yaw = np.deg2rad(yaw_deg)
    turn = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    obstacles = [_cylinder(-0.2)]
    turned_obstacles = [
        Obstacle(Shape("cylinder", turn @ o.shape.centre, 0.0, o.shape.half), o.clearance) for o in obstacles
    ]
    start, goal = START @ turn.T, GOAL @ turn.T
    d = start[1] - start[0]
    planner = HandMPC(SPEC, turned_obstacles, np.stack([turn, turn]), -np.arctan2(d[1], d[0]))
    turned = planner.step(0.0, HandState(start, np.zeros((2, 3)), 0.0), goal, PHASE_END, 0, CARRYING)
    _, result = _plan(obstacles, carrying=CARRYING)
    assert turned.success and result.success
    times = np.linspace(0.0, PHASE_END, 50)
    np.testing.assert_allclose(turned.plan.sample(times)[0], result.plan.sample(times)[0] @ turn.T, atol=1e-6)
    np.testing.assert_allclose(turned.plan.control_points[6], result.plan.control_points[6], atol=1e-6)


@pytest.mark.parametrize("obstacles", [[], [_cylinder(-0.2)]], ids=["free", "cylinder"])
def test_replan_from_the_plan_s_own_state_continues_the_same_plan(obstacles):
    planner, first = _plan(obstacles, carrying=CARRYING)
    t = 0.02
    positions, rotations = first.plan.sample(np.array([t]))
    rates = first.plan.rates(t)
    state = HandState(positions[0], rates[:6].reshape(2, 3), float(_headings(rotations)[0]), float(rates[6]))
    second = planner.step(t, state, GOAL, PHASE_END, 0, CARRYING)
    assert second.success and second.plan.start == t
    times = np.linspace(t, PHASE_END, 100)
    np.testing.assert_allclose(second.plan.sample(times)[0], first.plan.sample(times)[0], rtol=0, atol=0.02)


@pytest.mark.parametrize("obstacles", [[], [_cylinder(-0.2)]], ids=["free", "cylinder"])
def test_plan_rates_equal_central_differences_of_the_sampled_plan(obstacles):
    _, result = _plan(obstacles, carrying=CARRYING)
    plan, h = result.plan, 1e-6
    for t in (0.0 + 2 * h, 0.7, 2.5, 4.9):
        (p_plus, p_minus), (r_plus, r_minus) = plan.sample(np.array([t + h, t - h]))
        fd = np.r_[
            ((p_plus - p_minus) / (2 * h)).ravel(),
            (_headings(np.array([r_plus]))[0] - _headings(np.array([r_minus]))[0]) / (2 * h),
        ]
        np.testing.assert_allclose(plan.rates(t), fd, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(plan.rates(PHASE_END + 0.1), 0.0)


def _goal_with_raw_heading(raw: float) -> np.ndarray:
    """Two hand goals whose inter-hand direction + OFFSET is `raw` (mod 2 pi)."""
    angle = raw - OFFSET
    return np.array([[1.0, 0.0, 1.0], [1.0 + 0.3 * np.cos(angle), 0.3 * np.sin(angle), 1.0]])


def test_goal_heading_unwraps_to_the_heading_nearest_the_current_one():
    planner = HandMPC(SPEC, [], HOME, OFFSET)
    assert planner.goal_heading(_goal_with_raw_heading(-3.0), 3.0) == pytest.approx(2 * np.pi - 3.0, abs=1e-12)
    assert planner.goal_heading(_goal_with_raw_heading(3.0), -3.0) == pytest.approx(3.0 - 2 * np.pi, abs=1e-12)
    rng = np.random.default_rng(3)
    for raw, now in rng.uniform(-10, 10, (50, 2)):
        heading = planner.goal_heading(_goal_with_raw_heading(raw), now)
        assert abs(heading - now) <= np.pi + 1e-12
        assert np.cos(heading - raw) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("distance", [2.0, 0.5])
def test_a_phase_too_short_for_the_bounds_gets_their_least_horizon_in_closed_form_and_keeps_them(distance):
    remaining = 0.3  # < min_horizon: the plan gets min_horizon, then more
    T = SPEC.min_horizon
    # premise: at rest at both ends, covering `distance` in T needs a peak acceleration of at least 4 distance / T^2
    assert 4 * distance / T**2 > SPEC.max_acceleration[0]
    goal = START + [distance, 0.0, 0.0]
    planner, result = _plan(goal=goal, phase_end=remaining)
    assert result.success and result.plan.horizon > T
    curves = (np.r_[START.ravel(), 0.0], np.zeros(7), np.r_[goal.ravel(), 0.0])
    rates = (_speed_limits(), np.r_[SPEC.max_acceleration, SPEC.max_acceleration, SPEC.max_yaw_acceleration])
    assert result.plan.horizon == pytest.approx(least_horizon(*curves, *rates, SPEC.control_points), rel=1e-12)
    C, horizon = result.plan.control_points, result.plan.horizon
    assert np.all(np.abs(C @ difference_matrix(C.shape[1], 1, horizon).T) <= _speed_limits()[:, None] + 1e-6)
    np.testing.assert_allclose(result.plan.sample(np.array([horizon]))[0][0], goal, atol=1e-9)


def test_a_later_plan_whose_end_the_hands_fell_behind_gets_a_horizon_that_meets_the_bounds():
    goal = START + [1.0, 0.0, 0.0]
    planner, first = _plan(goal=goal)
    t = PHASE_END - 0.2  # the hands have not moved, 0.2 s before the plan's end: 1 m needs more than 1 s
    later = planner.step(t, HandState(START, np.zeros((2, 3)), 0.0), goal, PHASE_END, 0)
    assert first.success and later.success and later.plan.start == t
    assert later.plan.horizon > SPEC.min_horizon and later.plan.horizon > PHASE_END - t
    C, horizon = later.plan.control_points, later.plan.horizon
    assert np.all(np.abs(C @ difference_matrix(C.shape[1], 1, horizon).T) <= _speed_limits()[:, None] + 1e-6)


def test_the_closed_form_horizon_is_the_least_at_which_a_plan_of_its_shapes_meets_the_bounds():
    rng = np.random.default_rng(7)
    speeds = _speed_limits()
    accelerations = np.r_[SPEC.max_acceleration, SPEC.max_acceleration, SPEC.max_yaw_acceleration]
    for _ in range(300):
        start = rng.normal(size=7)
        goal, velocity = start + rng.normal(size=7) * rng.uniform(0.0, 3.0), rng.uniform(-1, 1, 7) * speeds
        curves = (start, velocity, goal, speeds, accelerations, SPEC.control_points)
        T = least_horizon(*curves)
        assert meets(T, *curves) and (T == 0.0 or not meets(0.99 * T, *curves))


def _within_bounds(C: np.ndarray, velocity: np.ndarray, T: float, speeds, accelerations) -> bool:
    """Whether `C` over `T`, its second point at the start `velocity`'s, meets the bounds at every hodograph point."""
    P = C.copy()
    P[:, 1] = C[:, 0] + velocity * T / (C.shape[1] - 1)
    v, a = P @ difference_matrix(P.shape[1], 1, T).T, P @ difference_matrix(P.shape[1], 2, T).T
    return bool(np.all(np.abs(v) <= speeds[:, None] + 1e-9) and np.all(np.abs(a) <= accelerations[:, None] + 1e-9))


def test_a_path_re_timed_in_closed_form_meets_the_bounds_there_and_not_one_percent_sooner():
    rng = np.random.default_rng(11)
    bounds = rate_bounds(SPEC)
    for _ in range(200):
        C = np.cumsum(rng.normal(size=(7, SPEC.control_points)) * rng.uniform(0.0, 0.5), axis=1)
        C[:, -3:] = C[:, -3:-2]  # at rest at the goal
        velocity = rng.uniform(-0.9, 0.9, 7) * bounds[0]
        T = retimed(C, velocity, *bounds)
        assert _within_bounds(C, velocity, T, *bounds) and _within_bounds(C, velocity, 1.5 * T, *bounds)
        assert T == 0.0 or not _within_bounds(C, velocity, 0.99 * T, *bounds)


def test_a_plan_slowed_by_tighter_bounds_returns_to_its_phase_s_end_when_they_are_lifted():
    goal = START + [2.0, 0.0, 0.0]
    planner, first = _plan(goal=goal, phase_end=10.0)
    assert first.success and first.plan.horizon == pytest.approx(10.0)
    speeds, accelerations = rate_bounds(SPEC)
    planner.sqp.set_bounds(0.1 * speeds, 0.01 * accelerations)  # the pads slip: the carry slows to a crawl
    slowed = planner.step(0.5, HandState(START, np.zeros((2, 3)), 0.0), goal, 10.0, 0)
    assert slowed.success and slowed.plan.start + slowed.plan.horizon > 15.0
    planner.sqp.set_bounds(speeds, accelerations)
    state = HandState(slowed.plan.sample(np.array([1.0]))[0][0], np.zeros((2, 3)), 0.0)
    back = planner.step(1.0, state, goal, 10.0, 0)
    assert back.success and back.plan.start + back.plan.horizon == pytest.approx(10.0)


def test_hands_faster_than_a_tightened_speed_bound_brake_at_the_acceleration_bound_within_the_phase():
    goal = START + [1.5, 0.0, 0.0]
    planner, first = _plan(goal=goal, phase_end=6.0)
    speeds, accelerations = rate_bounds(SPEC)
    accelerations = 0.3 * accelerations
    fast = HandState(START, np.tile([0.8, 0.0, 0.0], (2, 1)), 0.0)  # both hands at 0.8 m/s along x
    planner.sqp.set_bounds(0.25 * speeds, accelerations)  # the carry slows to a quarter of its speed
    slowed = planner.step(0.5, fast, goal, 6.0, 0)
    assert first.success and slowed.success and slowed.plan.horizon == pytest.approx(5.5)  # no stretch needed
    C, T = slowed.plan.control_points, slowed.plan.horizon
    velocity, acceleration = C @ difference_matrix(C.shape[1], 1, T).T, C @ difference_matrix(C.shape[1], 2, T).T
    assert velocity[0, 0] == pytest.approx(0.8)  # from the measured speed
    assert np.all(np.abs(acceleration) <= accelerations[:, None] + 1e-6)
    # each hodograph point within the slower bound or what braking at the acceleration bound leaves of 0.8 m/s
    brake = 0.8 - np.arange(velocity.shape[1]) * accelerations[0] * T / (C.shape[1] - 2)
    assert np.all(np.abs(velocity[:6]) <= np.maximum(0.25 * speeds[:6, None], brake) + 1e-6)


NEAR_START = Obstacle(Shape("cylinder", np.array([0.76, 0.5, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), CLEARANCE)


def test_a_start_inside_an_obstacle_s_margin_gets_a_plan_short_of_it_by_no_more_than_the_start_is():
    # hand 0 starts 8 cm inside the cylinder's clearance: every QP is feasible (the obstacle's slack), and the plan
    # goes no deeper than it starts
    planner, result = _plan([NEAR_START], phase_end=1.0)
    assert result.success
    inside = CLEARANCE - NEAR_START.shape.distance(START[:1])[0][0]
    assert 0.07 < inside < 0.09
    hands = result.plan.sample(np.linspace(0.0, result.plan.horizon, 200))[0].reshape(-1, 3)
    assert NEAR_START.shape.distance(hands)[0].min() >= CLEARANCE - inside - 5e-3


def test_a_phase_s_first_plan_that_wants_a_route_gets_it_on_the_next_step():
    planner = HandMPC(SPEC, [_cylinder(0.0)], HOME, OFFSET)
    args = (HandState(START, np.zeros((2, 3)), 0.0), GOAL, PHASE_END, 0, None)  # free hands: succeeds, not clean
    first = planner.step(0.0, *args)
    assert not first.routed and planner.awaiting is not None  # one SQP on this step
    solves, solve = [], planner.sqp.solve
    planner.sqp.solve = lambda *a, **k: solves.append(a) or solve(*a, **k)  # type: ignore[method-assign]
    second = planner.step(0.02, *args)
    assert second.routed and planner.awaiting is None
    assert len(solves) == 1  # the route's SQP alone on that step, not the plan's own step as well


def test_a_carry_blocked_on_the_straight_line_takes_the_line_s_plan_short_of_the_cylinder_then_its_route():
    # carried, the box cannot pass the cylinder on the straight line: that plan falls short of the clearance (the
    # slack), the next step runs the route's SQP alone, to a plan clear of it
    planner = HandMPC(SPEC, [_cylinder(0.0)], HOME, OFFSET)
    state = HandState(START, np.zeros((2, 3)), 0.0)
    line = planner.step(0.0, state, GOAL, PHASE_END, 0, CARRYING)
    assert line.success and line.shortfall > 0.05 and planner.awaiting is not None
    routed = planner.step(0.0, state, GOAL, PHASE_END, 0, CARRYING)
    assert routed.routed and routed.shortfall < 5e-3 and planner.awaiting is None
    assert routed.min_clearance >= -5e-3


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_phase_with_a_point_to_pass_gets_the_route_through_it_at_once(side):
    planner = HandMPC(SPEC, [_cylinder(0.0)], HOME, OFFSET)
    planner.via = np.array([1.7, 0.8 * side])  # beside the cylinder on the straight path, on either side
    result = planner.step(0.0, HandState(START, np.zeros((2, 3)), 0.0), GOAL, PHASE_END, 0, CARRYING)
    assert result.routed and planner.awaiting is None
    middle = result.plan.sample(np.linspace(0.0, PHASE_END, 200))[0].mean(axis=1)
    assert side * middle[np.argmin(np.abs(middle[:, 0] - 1.7)), 1] > 0.3  # passes the cylinder on the via's side
