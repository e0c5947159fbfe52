"""How far a box is turned from square between two pads, checked against SciPy's rotations, and how far one pad is
ahead of the other."""

import numpy as np
from scipy.spatial.transform import Rotation

from harmony_cli.maths.rotations import grip_shear, off_square_deg, pad_axis


def test_a_box_turned_about_the_vertical_is_off_square_by_its_turn_from_the_line_folded_to_45_deg():
    """For any line direction (with a small vertical part, which plan view ignores) and box yaw, the angle is the
    yaw from the line folded onto the nearest side axis: a quarter turn is square again."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        line_deg, yaw_deg = rng.uniform(-180, 180, 2)
        line = np.array([np.cos(np.radians(line_deg)), np.sin(np.radians(line_deg)), rng.uniform(-0.1, 0.1)])
        box_x = Rotation.from_euler("zyx", [yaw_deg, 0.0, 0.0], degrees=True).as_matrix()[:, 0]
        turn = (yaw_deg - line_deg) % 90.0
        assert np.isclose(off_square_deg(box_x, line), min(turn, 90.0 - turn), atol=1e-9)


def test_square_grips_are_zero_and_a_diagonal_grip_is_45_deg():
    square = Rotation.from_euler("z", 90, degrees=True).as_matrix()[:, 0]
    assert np.isclose(off_square_deg(square, np.array([1.0, 0.0, 0.0])), 0.0, atol=1e-9)
    assert np.isclose(off_square_deg(square, np.array([0.0, -2.0, 0.0])), 0.0, atol=1e-9)
    assert np.isclose(off_square_deg(np.array([1.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0])), 45.0)


def test_one_pad_ahead_of_the_other_is_the_shear_whatever_the_grip_heading_and_normal_convention():
    """Pads 0.3 m apart on an axis turned by any heading, the right one 12 mm ahead along the faces (and 5 cm higher,
    which plan view ignores): shear 12 mm, with the normals facing each other or given the same way."""
    for heading in np.radians([0.0, 37.0, -120.0, 90.0]):
        axis = np.array([np.cos(heading), np.sin(heading), 0.0])
        across = np.array([-np.sin(heading), np.cos(heading), 0.0])
        start = np.array([[1.0, 2.0, 1.2], [1.0, 2.0, 1.25]])
        hands = start + np.outer([0.0, 0.3], axis) + np.outer([0.0, 0.012], across)
        for normals in (np.array([axis, -axis]), np.array([axis, axis])):
            assert np.isclose(grip_shear(hands, pad_axis(normals)), 0.012)
        assert np.isclose(grip_shear(hands - np.outer([0.0, 0.012], across), pad_axis(np.array([axis, -axis]))), 0.0)
