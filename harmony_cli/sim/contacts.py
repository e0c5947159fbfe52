"""The box's contact points with each hand's pads, summed up for the logs: how many, how much of their friction
they use and how far PyBullet's contact normals lie from the box's faces.

Why: a held box is lost when the pads' friction runs out, and the friction the pads spend pushing against each other
(one pad ahead of the other turns their squeeze into a couple) is not there to carry the box's weight. A normal's
angle from the nearest face of the box says whether the engine's contacts follow the box as it turns: with contacts
made afresh every step (sim/world.py's BODY_FLAGS) it stays near zero; a contact kept from an earlier step keeps
the normal it was made with and pushes the box sideways."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

# PyBullet's getContactPoints fields
LINK_B, NORMAL_ON_B, NORMAL_FORCE, FRICTION_1, FRICTION_DIR_1, FRICTION_2, FRICTION_DIR_2 = 4, 7, 9, 10, 11, 12, 13


@dataclass(frozen=True)
class PadContacts:
    """Per hand: its pads' contact points with the box (count), their normal forces summed in PyBullet's order [N],
    |their summed friction force| over (friction coefficient x that sum) (1: sliding; nan without a pressing
    contact) and the largest angle of one's normal from the normal of the box's nearest face [deg] (nan without
    contact); beside them, what the box presses on robot links of no hand."""

    points: np.ndarray
    normal_N: np.ndarray
    friction_used: np.ndarray
    normal_off_face_deg: np.ndarray
    other_N: float = 0.0  # the normal force on robot links that are no hand's pads (the box against an arm) [N]
    other_links: tuple[int, ...] = ()  # those links (PyBullet indices), in order


@dataclass(frozen=True)
class ContactPoint:
    """One contact of the box with a robot link, as an engine reports it: the link, the contact normal (unit, in the
    world), its normal force [N] and its friction force (a vector in the contact plane) [N]."""

    link: int
    normal: np.ndarray
    normal_N: float
    friction_N: np.ndarray


def summarise(
    contacts: Iterable[ContactPoint],
    hands_of_link: dict[int, list[int]],
    n_hands: int,
    box_rotation: np.ndarray,
    friction: float,
) -> PadContacts:
    """`hands_of_link`: the hands whose pads a robot link is (links of no hand are summed apart); `box_rotation`
    (3, 3): the box's orientation; `friction`: the pad-box coefficient the engine uses."""
    points = np.zeros(n_hands, dtype=int)
    normal, force = np.zeros(n_hands), np.zeros((n_hands, 3))
    off = np.full(n_hands, np.nan)
    other, others = 0.0, set()
    for point in contacts:
        if point.link not in hands_of_link:
            other += point.normal_N
            others.add(point.link)
            continue
        # a face's normal is a column of the box's rotation: the largest |cosine| is the nearest face
        angle = float(np.degrees(np.arccos(min(1.0, float(np.abs(box_rotation.T @ point.normal).max())))))
        for h in hands_of_link[point.link]:
            points[h] += 1
            normal[h] += point.normal_N
            force[h] += point.friction_N
            off[h] = angle if np.isnan(off[h]) else max(off[h], angle)
    pressing = normal > 0.0
    used = np.full(n_hands, np.nan)
    used[pressing] = np.linalg.norm(force[pressing], axis=1) / (friction * normal[pressing])
    return PadContacts(points, normal, used, off, float(other), tuple(sorted(others)))


def pad_contacts(
    contacts: Sequence[tuple],
    hands_of_link: dict[int, list[int]],
    n_hands: int,
    box_rotation: np.ndarray,
    friction: float,
) -> PadContacts:
    """`contacts`: PyBullet's contact points of the box (A) with the robot (B), summarised; `friction`: the
    coefficient PyBullet uses between pad and box (the product of the two bodies' lateral frictions)."""
    return summarise(
        (
            ContactPoint(
                point[LINK_B],
                np.asarray(point[NORMAL_ON_B]),
                point[NORMAL_FORCE],
                point[FRICTION_1] * np.asarray(point[FRICTION_DIR_1])
                + point[FRICTION_2] * np.asarray(point[FRICTION_DIR_2]),
            )
            for point in contacts
        ),
        hands_of_link,
        n_hands,
        box_rotation,
        friction,
    )
