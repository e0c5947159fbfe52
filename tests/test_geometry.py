"""Signed distances to obstacles, checked against PyBullet, finite differences and the CasADi version."""

from __future__ import annotations

import casadi as cs
import numpy as np
import pytest
from conftest import needs_pybullet

from harmony_cli.maths.shapes import Shape, symbolic_distance, table_legs
from harmony_cli.scenario import TableSpec

try:  # PyBullet has wheels up to Python 3.11 only: the tests that use it are marked needs_pybullet
    import pybullet
    from pybullet_utils.bullet_client import BulletClient
except ImportError:
    pass

SHAPES = {
    "box": Shape("box", np.array([0.3, -0.2, 0.8]), 0.6, np.array([0.4, 0.25, 0.3])),
    "cylinder": Shape("cylinder", np.array([-0.1, 0.2, 1.0]), 0.3, np.array([0.3, 0.3, 0.5])),
    "sphere": Shape("sphere", np.array([0.2, 0.1, 0.9]), 0.0, np.full(3, 0.35)),
}
PROBE_RADIUS = 1e-3


def _points_at_distance(shape: Shape, rng, low: float, high: float, n: int) -> np.ndarray:
    """n points whose signed distance to `shape` lies in [low, high] (rejection sampling around the centre)."""
    reach = np.max(shape.half) + max(abs(low), abs(high))
    candidates = shape.centre + rng.uniform(-reach, reach, (200 * n, 3))
    d, _ = shape.distance(candidates)
    points = candidates[(d >= low) & (d <= high)][:n]
    assert len(points) == n
    return points


def _bullet_body(client, shape: Shape) -> int:
    if shape.kind == "box":
        collision = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=shape.half.tolist())
    elif shape.kind == "cylinder":
        collision = client.createCollisionShape(
            pybullet.GEOM_CYLINDER, radius=float(shape.half[0]), height=2 * float(shape.half[2])
        )
    else:
        collision = client.createCollisionShape(pybullet.GEOM_SPHERE, radius=float(shape.half[0]))
    orientation = pybullet.getQuaternionFromEuler([0.0, 0.0, shape.yaw])
    return client.createMultiBody(0, collision, -1, shape.centre.tolist(), orientation)


@pytest.fixture(scope="module")
def bullet():
    client = BulletClient(connection_mode=pybullet.DIRECT)
    yield client
    client.disconnect()


# Measured max |PyBullet - numpy| over these points: box 7.2e-4, cylinder 4.1e-4, sphere 2e-16 m. Always
# PyBullet larger, and exactly (sqrt(3) - 1) mm and (sqrt(2) - 1) mm: Bullet's 1 mm collision margin rounds the
# box's corners and the cylinder's rims. 2 mm bounds that with room to spare.
@needs_pybullet
@pytest.mark.parametrize("kind", SHAPES)
def test_signed_distance_outside_equals_pybullet_closest_point_distance(bullet, kind):
    shape = SHAPES[kind]
    body = _bullet_body(bullet, shape)
    probe = bullet.createMultiBody(
        0, bullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=PROBE_RADIUS), -1, [50.0, 50.0, 50.0]
    )
    points = _points_at_distance(shape, np.random.default_rng(1), 0.05, 1.5, 50)
    measured = []
    for p in points:
        bullet.resetBasePositionAndOrientation(probe, p.tolist(), [0, 0, 0, 1])
        closest = bullet.getClosestPoints(probe, body, 10.0)
        measured.append(min(c[8] for c in closest) + PROBE_RADIUS)
    expected, _ = shape.distance(points)
    np.testing.assert_allclose(measured, expected, rtol=0, atol=2e-3)


def _away_from_medial_axis(shape: Shape, points: np.ndarray, gap: float = 1e-3) -> np.ndarray:
    """Inside points where the nearest face is unique by `gap` (the signed distance is smooth there)."""
    local = shape._to_local(points)
    if shape.kind == "sphere":
        return np.linalg.norm(local, axis=1) > gap
    if shape.kind == "cylinder":
        radial = np.linalg.norm(local[:, :2], axis=1)
        faces = np.stack([shape.half[0] - radial, shape.half[2] - local[:, 2], shape.half[2] + local[:, 2]], 1)
        ok = radial > gap
    else:
        faces = np.hstack([shape.half - local, shape.half + local])
        ok = np.ones(len(points), dtype=bool)
    nearest_two = np.sort(faces, axis=1)[:, :2]
    return ok & (nearest_two[:, 1] - nearest_two[:, 0] > gap)


@pytest.mark.parametrize("kind", SHAPES)
def test_gradient_equals_central_differences_outside_and_inside(rng, kind):
    shape, eps = SHAPES[kind], 1e-6
    outside = _points_at_distance(shape, rng, 1e-3, 1.0, 100)
    inside = _points_at_distance(shape, rng, -0.3, -1e-3, 100)
    inside = inside[_away_from_medial_axis(shape, inside)]
    assert len(inside) > 50
    points = np.vstack([outside, inside])
    _, gradient = shape.distance(points)
    fd = np.stack(
        [(shape.distance(points + eps * e)[0] - shape.distance(points - eps * e)[0]) / (2 * eps) for e in np.eye(3)],
        axis=1,
    )
    np.testing.assert_allclose(gradient, fd, rtol=0, atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(gradient, axis=1), 1.0, atol=1e-12)


def _casadi_distance(kind: str, half: np.ndarray, planar: bool = False) -> cs.Function:
    point, centre, yaw = cs.SX.sym("point", 3), cs.SX.sym("centre", 3), cs.SX.sym("yaw")
    return cs.Function("d", [point, centre, yaw], [symbolic_distance(kind, half, centre, yaw, point, planar)])


def _random_pose(shape: Shape, rng) -> Shape:
    return Shape(shape.kind, rng.uniform(-2, 2, 3), float(rng.uniform(-np.pi, np.pi)), shape.half)


# Inside, the CasADi version's smoothing sqrt(0 + 1e-12) adds 1e-6 exactly, and a cylinder's radius
# sqrt(r^2 + 1e-12) adds 5e-13 / r more (< 1e-9 at r > 1 mm): 1e-6 plus that.
TOL_SYMBOLIC = 1e-6 + 1e-9


@pytest.mark.parametrize("kind", SHAPES)
def test_casadi_distance_equals_numpy_distance_inside_and_outside(rng, kind):
    f = _casadi_distance(kind, SHAPES[kind].half)
    for _ in range(5):
        shape = _random_pose(SHAPES[kind], rng)
        points = np.vstack(
            [_points_at_distance(shape, rng, 1e-3, 1.5, 20), _points_at_distance(shape, rng, -0.3, -1e-3, 20)]
        )
        symbolic = np.array([float(f(p, shape.centre, shape.yaw)) for p in points])
        np.testing.assert_allclose(symbolic, shape.distance(points)[0], rtol=0, atol=TOL_SYMBOLIC)


def _at_centre_height(shape: Shape, points: np.ndarray) -> np.ndarray:
    moved = points.copy()
    moved[:, 2] = shape.centre[2]
    return moved


@pytest.mark.parametrize("kind", SHAPES)
def test_planar_casadi_distance_is_the_distance_at_the_centre_height_of_a_shape_taller_than_wide(rng, kind):
    # At the centre height the top and bottom are half[2] away, so they are never the nearest face when
    # half[2] >= min(half[0], half[1]) (true of all three shapes): the 3-D distance there is the x, y one.
    assert SHAPES[kind].half[2] >= min(SHAPES[kind].half[:2])
    f = _casadi_distance(kind, SHAPES[kind].half, planar=True)
    for _ in range(5):
        shape = _random_pose(SHAPES[kind], rng)
        points = shape.centre + rng.uniform(-0.8, 0.8, (60, 3))  # any height: planar ignores z
        symbolic = np.array([float(f(p, shape.centre, shape.yaw)) for p in points])
        expected, _ = shape.distance(_at_centre_height(shape, points))
        assert np.any(expected < 0) and np.any(expected > 0)
        np.testing.assert_allclose(symbolic, expected, rtol=0, atol=TOL_SYMBOLIC)


@pytest.mark.parametrize("kind", ["box", "cylinder"])
def test_planar_casadi_distance_of_a_flat_shape_is_the_distance_to_its_footprint_extruded(rng, kind):
    half = np.array([0.4, 0.4 if kind == "cylinder" else 0.25, 0.02])  # a table top: half height << half width
    f = _casadi_distance(kind, half, planar=True)
    shape = Shape(kind, np.array([0.5, -0.3, 1.0]), 0.4, half)
    extruded = Shape(kind, shape.centre, shape.yaw, np.r_[half[:2], 10.0])
    points = shape.centre + rng.uniform(-1.0, 1.0, (200, 3))
    symbolic = np.array([float(f(p, shape.centre, shape.yaw)) for p in points])
    flat = _at_centre_height(shape, points)
    np.testing.assert_allclose(symbolic, extruded.distance(flat)[0], rtol=0, atol=TOL_SYMBOLIC)
    # ... which differs from the flat shape's own distance inside, where its top is nearer than its sides
    assert np.any(np.abs(symbolic - shape.distance(flat)[0]) > 0.1)


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 90.0])
def test_four_table_legs_stand_on_the_floor_under_the_top_inside_its_footprint(yaw_deg):
    table = TableSpec(name="t", position=(2.3, -1.1), yaw_deg=yaw_deg, top=(1.5, 0.8), height=1.015, thickness=0.03)
    legs = table_legs(table)
    assert len(legs) == 4
    yaw = np.deg2rad(yaw_deg)
    to_table = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])
    corners = np.array([[sx, sy] for sx in (-1, 1) for sy in (-1, 1)])
    offsets = []
    for leg in legs:
        assert leg.kind == "box" and leg.yaw == pytest.approx(yaw)
        assert leg.centre[2] - leg.half[2] == pytest.approx(0.0, abs=1e-12)
        assert leg.centre[2] + leg.half[2] == pytest.approx(table.height - table.thickness, abs=1e-12)
        c, s = np.cos(leg.yaw), np.sin(leg.yaw)
        footprint = leg.centre[:2] + (corners * leg.half[:2]) @ np.array([[c, s], [-s, c]])
        in_table = (footprint - np.array(table.position)) @ to_table.T
        assert np.all(np.abs(in_table) <= np.array(table.top) / 2 + 1e-12)
        offsets.append((leg.centre[:2] - np.array(table.position)) @ to_table.T)
    assert {tuple(np.sign(o)) for o in offsets} == {(-1, -1), (-1, 1), (1, -1), (1, 1)}


def test_a_box_s_plan_view_corners_lie_on_its_outline_counter_clockwise():
    box = Shape("box", np.array([1.0, -2.0, 0.5]), 0.7, np.array([0.4, 0.25, 0.5]))
    corners = box.corners()
    distance, _ = box.distance(np.column_stack([corners, np.full(4, 0.5)]))
    np.testing.assert_allclose(distance, 0.0, atol=1e-12)
    edges = np.roll(corners, -1, axis=0) - corners
    assert np.all(edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0] > 0)
