"""The squeeze while a box is held follows the load the wrists measure (planning/grip_force.py)."""

import numpy as np
import pytest

from harmony_cli.planning.grip_force import FALL, GRAVITY, RECOVER, RISE, SLOWEST, GripForce, GripLaw
from harmony_cli.planning.hand_mpc import HandMPC
from harmony_cli.planning.hand_plan import HandState
from harmony_cli.scenario import PlannerSpec

BOX = {"size": (0.3, 0.3), "width": 0.3}
LAW = GripLaw(mass=1.2, **BOX, friction=0.8, margin=2.0, scale=2.0, filter=0.0)
DT = 0.02


def _wrenches(tangential: float, normal: float = 20.0) -> np.ndarray:
    """Both wrists: `tangential` [N] along the pad's face (split over x and y), `normal` pressing on the pad."""
    w = np.zeros((2, 6))
    w[:, 0], w[:, 1], w[:, 2] = 0.6 * tangential, 0.8 * tangential, -normal
    return w


def test_the_squeeze_holds_the_weight_with_the_margin_when_the_wrists_see_no_more():
    grip = GripForce(GripLaw(mass=3.0, **BOX, friction=0.5, margin=2.0, scale=4.0, filter=0.0), DT)
    written = np.full((2, 5), 20.0)
    for _ in range(200):
        force = grip(written, _wrenches(0.0), holding=True)
    assert force == pytest.approx(np.full((2, 5), 2.0 * 0.5 * 3.0 * GRAVITY / 0.5))  # mu F = margin m g / 2


def test_the_squeeze_rises_with_the_tangential_load_at_the_rise_rate_and_stops_at_the_cap():
    grip, written = GripForce(LAW, DT), np.full((2, 3), 20.0)
    forces = [grip(written, _wrenches(12.0), holding=True)[0, 0] for _ in range(100)]
    assert forces[0] == pytest.approx(20.0 + RISE * DT)
    assert np.diff(forces).max() <= RISE * DT + 1e-9
    assert forces[-1] == pytest.approx(min(2.0 * 12.0 / 0.8, 2.0 * 20.0))


def test_the_squeeze_falls_back_slowly_when_the_load_goes():
    grip, written = GripForce(LAW, DT), np.full((2, 3), 20.0)
    for _ in range(100):
        grip(written, _wrenches(12.0), holding=True)
    high = grip(written, _wrenches(12.0), holding=True)[0, 0]
    low = grip(written, _wrenches(0.0), holding=True)[0, 0]
    assert high - low == pytest.approx(FALL * DT)


def test_nothing_changes_while_the_box_is_not_held():
    grip, written = GripForce(LAW, DT), np.full((2, 3), 20.0)
    assert grip(written, _wrenches(50.0), holding=False) is written
    assert np.isnan(grip.friction_used)


def test_the_friction_used_is_the_tangential_over_mu_times_the_normal_force():
    grip = GripForce(LAW, DT)
    grip(np.full((2, 3), 20.0), _wrenches(8.0, normal=25.0), holding=True)
    assert grip.friction_used == pytest.approx(8.0 / (0.8 * 25.0))


def test_at_the_acceleration_bounds_the_pads_use_their_friction_over_the_margin():
    law = GripLaw(mass=1.5, **BOX, friction=0.8, margin=2.0, scale=1.0, filter=0.0)
    horizontal, vertical, yaw = law.accelerations(20.0)
    hold = 0.8 * 20.0 / 2.0  # per pad, with the margin
    assert np.hypot(1.5 * GRAVITY / 2, 1.5 * horizontal / 2) == pytest.approx(hold)  # weight and push, each pad
    assert 1.5 * (GRAVITY + vertical) / 2 == pytest.approx(hold)
    # the yaw torque I alpha from the two pads' opposite forces, what the weight leaves of each, half a width out
    inertia = 1.5 * (0.3**2 + 0.3**2) / 12
    assert inertia * yaw == pytest.approx(np.sqrt(hold**2 - (1.5 * GRAVITY / 2) ** 2) * 0.3)


def test_the_carry_slows_while_the_wrists_see_the_pads_slide_and_recovers_at_its_rate():
    grip, written = GripForce(LAW, DT), np.full((2, 3), 20.0)
    speeds, accelerations = np.full(7, 0.8), np.full(7, 1.0)
    grip(written, _wrenches(8.0, normal=20.0), holding=True)  # half the friction used: the margin's, full pace
    assert grip.pace == 1.0
    held_accelerations = grip.bounds(speeds, accelerations, 20.0)[1]
    grip(written, _wrenches(16.0, normal=20.0), holding=True)  # sliding
    slow_speeds, slow_accelerations = grip.bounds(speeds, accelerations, 20.0)
    assert grip.pace == SLOWEST
    np.testing.assert_allclose(slow_speeds, SLOWEST * speeds)
    np.testing.assert_allclose(slow_accelerations, held_accelerations)  # the grip's: slowing down needs them
    grip(written, _wrenches(0.0), holding=True)
    assert grip.pace == pytest.approx(SLOWEST + RECOVER * DT)


def test_a_plan_under_slower_bounds_meets_them_by_taking_longer():
    spec = PlannerSpec()
    start = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])
    state, goal = HandState(start, np.zeros((2, 3)), 0.0), start + [2.0, 0.0, 0.0]
    planner = HandMPC(spec, [], np.stack([np.eye(3), np.eye(3)]), np.pi / 2)
    fast = planner.step(0.0, state, goal, 3.0, 0)
    speeds = np.r_[spec.max_speed, spec.max_speed, spec.max_yaw_rate]
    accelerations = np.r_[spec.max_acceleration, spec.max_acceleration, spec.max_yaw_acceleration]
    planner.sqp.set_bounds(0.25 * speeds, accelerations)
    slow = planner.step(0.02, state, goal, 3.0, 0)
    assert slow.success and slow.plan.horizon > 2.0 * fast.plan.horizon
    times = slow.plan.start + np.linspace(0.0, slow.plan.horizon, 200, endpoint=False)
    rates = np.array([slow.plan.rates(t) for t in times])
    assert (np.abs(rates) <= 0.25 * speeds + 1e-6).all()
