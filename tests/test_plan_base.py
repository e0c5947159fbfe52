"""The base as the task-space planner sees it (footprint carried behind the hands), goals and starts inside a
clearance."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.bezier import bernstein_basis
from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState, Obstacle, Outcome
from harmony_cli.planning.plan_base import PlannedBase
from harmony_cli.scenario import PlannerSpec

SPEC = PlannerSpec(step_iterations=PlannerSpec().phase_iterations)  # first plans in one step: test_first_plan.py
HOME = np.stack([np.eye(3), np.eye(3)])
OFFSET = np.pi / 2  # hand 0 at +y, hand 1 at -y: heading 0 faces +x
START = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
GOAL = START + [3.5, 0.0, 0.0]
CIRCLES = np.array([[0.2, 0.2, 0.3], [-0.2, 0.2, 0.3], [0.2, -0.2, 0.3], [-0.2, -0.2, 0.3]])  # x, y, r (base frame)
HAND_CLEARANCE, BASE_CLEARANCE = 0.13, 0.3


def _cylinder(x: float, y: float, clearance: float) -> Obstacle:
    return Obstacle(Shape("cylinder", np.array([x, y, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), clearance)


def _base(bodies: list[Obstacle], yaw: float = 0.0) -> PlannedBase:
    return PlannedBase.at_home(CIRCLES, np.array([0.0, 0.0, yaw]), START, bodies)


def test_footprint_margin_jacobian_equals_finite_differences():
    rng = np.random.default_rng(0)
    box = Obstacle(Shape("box", np.array([0.5, -1.0, 0.5]), 0.4, np.array([0.3, 0.2, 0.5])), 0.03)
    base = _base([_cylinder(1.0, 0.3, BASE_CLEARANCE), box], yaw=0.3)
    M, S = 8, 10
    s = np.linspace(0, 1, S + 1)[1:]
    B, free = bernstein_basis(M, s), np.r_[False, False, np.ones(M - 5, bool), False, False, False]
    C = 0.5 * rng.normal(size=(7, M)) + np.r_[1.2, 0.3, 1.2, 1.2, -0.3, 1.2, 0.0][:, None]
    C[[0, 3], :2], C[[0, 3], -3:] = -3.0, 5.0  # fixed ends clear of both bodies (nothing to relieve)

    def rows(C):  # every row, the inactive ones 0 (rows returns the active ones only)
        margins = base.margins((0.5 * (C[0:2] + C[3:5]) @ B.T).T, C[6] @ B.T, s)[0]
        r, J, _ = base.rows(np.column_stack([C[:, 0], C @ B.T]), np.r_[0.0, s], 10.0, B[:, free].T.copy())
        full, full_J = np.zeros(2 * S), np.zeros((2 * S, J.shape[1]))
        active = np.flatnonzero(margins.ravel() < 0.0)  # no reliefs: the ends are clear
        full[active], full_J[active] = r, J
        return full, full_J

    r, J = rows(C)
    assert (r < 0).sum() >= 3  # the footprint overlaps the bodies somewhere: rows are active
    numeric = np.zeros_like(J)
    for column in range(J.shape[1]):
        moved = C.copy()
        moved[column // free.sum(), np.flatnonzero(free)[column % free.sum()]] += 1e-7
        numeric[:, column] = (rows(moved)[0] - r) / 1e-7
    np.testing.assert_allclose(J, numeric, atol=1e-5)


def test_footprint_margin_equals_the_circles_distance_to_a_cylinder_by_hand():
    cylinder = _cylinder(0.5, 1.2, BASE_CLEARANCE)
    base = _base([cylinder], yaw=0.4)
    midpoints, headings = np.array([[1.0, 0.5], [-0.3, 0.2]]), np.array([0.2, -1.1])
    margins = base.margins(midpoints, headings, np.zeros(2))[0][0]
    rot = lambda a: np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    hands_in_base = rot(0.4).T @ START[:, :2].mean(axis=0)  # the base stands at the origin at home
    for midpoint, heading, margin in zip(midpoints, headings, margins):
        rotation = rot(0.4 + heading)
        circles = midpoint - rotation @ hands_in_base + CIRCLES[:, :2] @ rotation.T
        by_hand = np.linalg.norm(circles - [0.5, 1.2], axis=1) - 0.3 - CIRCLES[:, 2] - BASE_CLEARANCE
        assert abs(margin - by_hand.min()) < 1e-12


def test_screen_is_a_lower_bound_of_the_footprint_margin():
    # a body the screen puts above 0 would add no row: the bound must never exceed the true margin
    rng = np.random.default_rng(1)
    box = Obstacle(Shape("box", np.array([0.5, -1.0, 0.5]), 0.4, np.array([0.3, 0.2, 0.5])), 0.03)
    cylinder = _cylinder(1.0, 0.3, BASE_CLEARANCE)
    moving = Obstacle(cylinder.shape, BASE_CLEARANCE, lambda t: cylinder.shape.centre + np.outer(t, [0.5, -0.2, 0]))
    base = _base([cylinder, box, moving], yaw=0.3)
    midpoints, headings = rng.uniform(-3.0, 4.0, size=(500, 2)), rng.uniform(-np.pi, np.pi, 500)
    times = rng.uniform(0.0, 4.0, 500)
    margins = base.margins(midpoints, headings, times)[0]
    bounds = np.array([base.screen(m[:1], m[1:], h[None], t[None]) for m, h, t in zip(midpoints, headings, times)]).T
    assert (bounds <= margins + 1e-12).all()
    assert (bounds > 0).any() and (margins < 0).any()  # both kinds of sample were drawn
    assert (margins - bounds).min() < 0.1  # and tight where the footprint points at the body


def _plan(obstacles: list[Obstacle], base: PlannedBase | None, goal=GOAL):
    """The first plan taken: the search's steps until it ends (a route's after a line's plan that is not clean)."""
    planner = HandMPC(SPEC, obstacles, HOME, OFFSET, None, base)
    for _ in range(3):
        result = planner.step(0.0, HandState(START, np.zeros((2, 3)), 0.0), goal, 6.0, 0)
        if result.outcome is not Outcome.SEARCHING:
            return result
    raise AssertionError("the first plan's search did not end")


def _footprint_margins(base: PlannedBase, result) -> np.ndarray:
    positions, rotations = result.plan.sample(np.linspace(0.0, result.plan.horizon, 200))
    headings = np.arctan2(rotations[:, 0, 1, 0], rotations[:, 0, 0, 0])
    return base.margins(positions[:, :, :2].mean(axis=1), headings, np.zeros(200))[0]


def test_plan_steps_aside_so_the_base_behind_the_hands_clears_a_cylinder_the_hands_alone_would_pass():
    # the hands pass 5 cm clear of the cylinder; the base's circles, 0.3 m wider, would run into its margin
    hands_only, footprint = _cylinder(2.0, 0.63, HAND_CLEARANCE), _cylinder(2.0, 0.63, BASE_CLEARANCE)
    base = _base([footprint])
    alone = _plan([hands_only], None)
    guided = _plan([hands_only], base)
    assert alone.success and guided.success
    assert _footprint_margins(base, alone).min() < -0.3
    assert _footprint_margins(base, guided).min() > -0.05
    np.testing.assert_allclose(guided.plan.sample(np.array([guided.plan.horizon]))[0][0], GOAL, atol=1e-9)


def test_a_goal_inside_an_obstacle_s_clearance_is_still_reached_keeping_as_far_as_the_goal_is():
    cylinder = _cylinder(GOAL[1, 0] + 0.24, -0.15 - 0.32, HAND_CLEARANCE)  # hand 1's goal 3 cm inside the clearance
    inside = cylinder.shape.distance(GOAL)[0].min()
    assert HAND_CLEARANCE - 0.04 < inside < HAND_CLEARANCE - 0.02
    result = _plan([cylinder], None)
    assert result.success
    positions, _ = result.plan.sample(np.linspace(0.0, result.plan.horizon, 200))
    np.testing.assert_allclose(positions[-1], GOAL, atol=1e-9)
    assert cylinder.shape.distance(positions.reshape(-1, 3))[0].min() > inside - 0.006


def test_a_hand_starting_inside_two_margins_that_pull_apart_gets_a_plan_out_at_about_its_start_s_depth():
    # hand 0 starts 0.1 m from two cylinders on either side (clearance 0.13): the rows ask it to move +y and -y at
    # once, which no plan meets; each obstacle's slack takes the start's shortfall, and the plan slides out along x
    gap = 0.1
    sides = [_cylinder(START[0, 0], START[0, 1] + sign * (0.3 + gap), HAND_CLEARANCE) for sign in (1, -1)]
    result = _plan(sides, None)
    assert result.success and result.shortfall > 0.0
    positions, _ = result.plan.sample(np.linspace(0.0, result.plan.horizon, 300))
    nearest = np.minimum(*(side.shape.distance(positions[:, 0])[0] for side in sides))
    # the hand's slack for each cylinder is its start's shortfall, which its other samples may use as well: the
    # plan keeps near the start's depth, not deeper than it by more than a centimetre
    assert nearest.min() > gap - 0.01
    np.testing.assert_allclose(positions[-1], GOAL, atol=1e-9)


def test_plan_view_distances_equal_each_shape_s_own_distance():
    # plan_base's plan-view distance against maths/shapes.py's Shape.distance, box and cylinder, in and outside
    from harmony_cli.planning.plan_base import _plan_distance

    rng = np.random.default_rng(3)
    shapes = [
        Shape("box", np.array([0.5, -1.0, 0.5]), 0.4, np.array([0.3, 0.2, 0.5])),
        Shape("cylinder", np.array([1.0, 0.3, 1.0]), 0.0, np.array([0.6, 0.6, 1.0])),
    ]
    points = rng.uniform(-1.5, 2.0, size=(40, 2))
    for shape in shapes:
        dist, gx, gy = _plan_distance(
            points[:, 0:1], points[:, 1:2], shape.centre[None, :2], shape.yaw, shape.half[:2], shape.kind != "box"
        )
        expected, expected_grad = shape.distance(np.column_stack([points, np.full(40, shape.centre[2])]))
        assert (expected < 0).any() and (expected > 0).any()
        np.testing.assert_allclose(dist[:, 0], expected, atol=1e-12)
        np.testing.assert_allclose(np.column_stack([gx[:, 0], gy[:, 0]]), expected_grad[:, :2], atol=1e-12)
