"""Shape.distance as compiled C (the planner's clearance rows) against the numpy code in maths/shapes.py."""

from __future__ import annotations

import numpy as np
import pytest

from harmony_cli.maths.shapes import Shape
from harmony_cli.mpc.distance_code import CompiledDistance

SHAPES = {
    "box": Shape("box", np.array([0.5, -1.0, 0.5]), 0.4, np.array([0.3, 0.2, 0.5])),
    "cylinder": Shape("cylinder", np.array([1.5, 0.3, 1.0]), 0.0, np.array([0.3, 0.3, 1.0])),
    "sphere": Shape("sphere", np.array([-1.0, 0.5, 1.0]), 0.0, np.array([0.2, 0.2, 0.2])),
}


@pytest.mark.parametrize("kind", SHAPES)
def test_compiled_distance_and_gradient_equal_the_numpy_ones_to_the_bit_inside_outside_and_grown(kind):
    shape, rng = SHAPES[kind], np.random.default_rng(1)
    compiled, inside = CompiledDistance(shape, 60), 0
    for _ in range(30):
        points = shape.centre + rng.uniform(-1.0, 1.0, (60, 3)) * (shape.half + 0.3)
        grow = rng.uniform(0.0, 0.2)
        compiled.grow[:40], compiled.grow[40:] = 0.0, grow  # the hands as they are, the object against it grown
        distance, gradient = compiled.distance(points)
        hands, carried = shape.distance(points[:40]), shape.grown(grow).distance(points[40:])
        np.testing.assert_array_equal(distance, np.r_[hands[0], carried[0]])
        np.testing.assert_array_equal(gradient, np.r_[hands[1], carried[1]])
        inside += int((distance < 0).sum())
    assert inside > 100  # the inside branch (nearest face) was compared, not only the outside one
