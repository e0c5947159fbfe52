"""The squeeze while a box is held follows the load the wrists measure (planning/grip_force.py)."""

import numpy as np
import pytest

from harmony_cli.planning.grip_force import FALL, GRAVITY, RISE, GripForce, GripLaw

LAW = GripLaw(mass=1.2, friction=0.8, margin=2.0, scale=2.0, filter=0.0)
DT = 0.02


def _wrenches(tangential: float, normal: float = 20.0) -> np.ndarray:
    """Both wrists: `tangential` [N] along the pad's face (split over x and y), `normal` pressing on the pad."""
    w = np.zeros((2, 6))
    w[:, 0], w[:, 1], w[:, 2] = 0.6 * tangential, 0.8 * tangential, -normal
    return w


def test_the_squeeze_holds_the_weight_with_the_margin_when_the_wrists_see_no_more():
    grip = GripForce(GripLaw(mass=3.0, friction=0.5, margin=2.0, scale=4.0, filter=0.0), DT)
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
