"""The box's contact points with the pads, summed per hand (sim/contacts.py), on contact points written by hand in
PyBullet's getContactPoints layout."""

import numpy as np

from harmony_cli.maths.rotations import rot_z
from harmony_cli.sim.contacts import pad_contacts


def _point(link: int, normal, force: float, friction_1: float, friction_2: float = 0.0) -> tuple:
    """A getContactPoints tuple: link on B at 4, normal on B at 7, normal force at 9, the two frictions at 10-13."""
    return (
        0,
        1,
        2,
        -1,
        link,
        (0, 0, 0),
        (0, 0, 0),
        tuple(normal),
        0.0,
        force,
        friction_1,
        (0, 0, 1),
        friction_2,
        (1, 0, 0),
    )


def test_a_normal_left_behind_by_a_turn_is_its_angle_off_the_box_face_and_friction_use_is_a_cone_fraction():
    box = rot_z(np.deg2rad(30.0))  # the box has turned 30 deg; one of the left pad's normals has not
    face = box[:, 0]
    contacts = [
        _point(14, face, 10.0, 3.0, 4.0),  # along the face: 0 deg; friction (4, 0, 3)
        _point(14, (1.0, 0.0, 0.0), 10.0, 1.0),  # made before the turn: 30 deg off
        _point(23, -face, 20.0, -4.0),  # the right pad
        _point(7, face, 50.0, 9.0),  # a link of neither hand
    ]
    out = pad_contacts(contacts, {14: [0], 23: [1]}, 2, box, friction=0.8)
    assert out.points.tolist() == [2, 1]
    assert out.normal_N.tolist() == [20.0, 20.0]
    assert np.allclose(out.normal_off_face_deg, [30.0, 0.0])
    # left: |(4, 0, 3) + (0, 0, 1)| / (0.8 x 20); right: 4 / (0.8 x 20)
    assert np.allclose(out.friction_used, [np.hypot(4.0, 4.0) / 16.0, 4.0 / 16.0])
    assert out.other_N == 50.0 and out.other_links == (7,)  # the box pressing on a link that is no pad


def test_a_hand_without_contact_has_no_friction_use_and_no_normal_angle():
    out = pad_contacts([], {14: [0]}, 2, np.eye(3), friction=0.8)
    assert (
        out.points.tolist() == [0, 0] and np.isnan(out.friction_used).all() and np.isnan(out.normal_off_face_deg).all()
    )
