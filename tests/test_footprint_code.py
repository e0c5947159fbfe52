"""The planned base's footprint margins with their nearest circles found in compiled C, against numpy's search."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.footprint_code import CompiledMargins
from harmony_cli.planning.hand_plan import Obstacle
from harmony_cli.planning.plan_base import PlannedBase

CIRCLES = np.array([[0.3, 0.2, 0.25], [-0.3, 0.2, 0.25], [0.3, -0.2, 0.25], [-0.3, -0.2, 0.25], [0.0, 0.0, 0.3]])
HANDS = np.array([[0.76, 0.15, 0.93], [0.76, -0.15, 0.93]])


def _bodies() -> list[Obstacle]:
    """A turned box, a cylinder, a box that moves, a sphere (round in plan view)."""
    moving = Shape("box", np.array([1.0, 1.0, 0.5]), 0.0, np.array([0.2, 0.4, 0.5]))
    return [
        Obstacle(Shape("box", np.array([0.5, -1.0, 0.5]), 0.4, np.array([0.3, 0.2, 0.5])), 0.03),
        Obstacle(Shape("cylinder", np.array([1.5, 0.3, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])), 0.2),
        Obstacle(moving, 0.05, lambda t: moving.centre + np.outer(t, [0.3, -0.2, 0.0])),
        Obstacle(Shape("sphere", np.array([-1.0, 0.5, 1.0]), 0.0, np.array([0.2, 0.2, 0.2])), 0.1),
    ]


def test_compiled_footprint_margins_and_gradients_equal_the_numpy_ones_to_the_bit_near_and_far_from_bodies():
    base = PlannedBase.at_home(CIRCLES, np.array([0.0, 0.0, 0.2]), HANDS, _bodies())
    samples, rng = 21, np.random.default_rng(3)
    compiled = CompiledMargins(base, samples)
    inside = 0
    for _ in range(20):
        midpoints, headings = rng.uniform(-1.5, 2.0, (samples, 2)), rng.uniform(-np.pi, np.pi, samples)
        times = np.sort(rng.uniform(0.0, 3.0, samples))
        near = rng.random(len(base.bodies)) < 0.7
        expected = base.margins(midpoints, headings, times, near)
        got = base.margins(midpoints, headings, times, near, nearest=compiled)
        for e, g in zip(expected, got):
            np.testing.assert_array_equal(g, e)
        inside += int((expected[0] < 0).sum())
    assert inside > 20  # footprints within a clearance (active rows) were compared, not only clear ones


def test_compiled_footprint_rows_and_smallest_margin_equal_numpys_to_the_bit():
    base = PlannedBase.at_home(CIRCLES, np.array([0.0, 0.0, 0.2]), HANDS, _bodies())
    samples, rng = 21, np.random.default_rng(5)
    compiled, basis = CompiledMargins(base, samples + 1), rng.uniform(0.0, 1.0, (6, samples))
    active = 0
    for _ in range(20):
        curves = rng.uniform(-1.5, 2.0, (7, samples + 1))
        times = np.sort(rng.uniform(0.0, 3.0, samples + 1))
        r, J, smallest = base.rows(curves, times, 2.0, basis)
        r_c, J_c, smallest_c = base.rows(curves, times, 2.0, basis, nearest=compiled)
        np.testing.assert_array_equal(r_c, r)
        np.testing.assert_array_equal(J_c, J)
        assert smallest_c == smallest
        active += len(r)
    assert active > 20  # footprints within a clearance (active rows) were compared, not only clear ones
