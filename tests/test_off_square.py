"""How far a box is turned from square in a grip, checked against SciPy's rotations (an independent quaternion
convention and composition)."""

import numpy as np
from scipy.spatial.transform import Rotation

from harmony_cli.maths.rotations import off_square_deg


def test_a_box_turned_about_the_vertical_is_off_square_by_its_turn_from_the_line_folded_to_45_deg():
    """For any line direction and box yaw (and a small tilt, which plan view ignores to first order), the angle is the
    yaw from the line folded onto the nearest side axis: a quarter turn is square again."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        line_deg, yaw_deg = rng.uniform(-180, 180, 2)
        line = np.array([np.cos(np.radians(line_deg)), np.sin(np.radians(line_deg)), rng.uniform(-0.1, 0.1)])
        quaternion = Rotation.from_euler("zyx", [yaw_deg, 0.0, 0.0], degrees=True).as_quat()  # x, y, z, w
        turn = (yaw_deg - line_deg) % 90.0
        assert np.isclose(off_square_deg(quaternion, line), min(turn, 90.0 - turn), atol=1e-9)


def test_square_grips_are_zero_and_a_diagonal_grip_is_45_deg():
    square = Rotation.from_euler("z", 90, degrees=True).as_quat()
    assert np.isclose(off_square_deg(square, np.array([1.0, 0.0, 0.0])), 0.0, atol=1e-9)
    assert np.isclose(off_square_deg(square, np.array([0.0, -2.0, 0.0])), 0.0, atol=1e-9)
    assert np.isclose(off_square_deg(np.array([0, 0, 0, 1.0]), np.array([1.0, 1.0, 0.0])), 45.0)
