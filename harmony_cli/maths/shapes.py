"""Shapes of the scene (box, vertical cylinder, sphere): obstacles and table legs from their scenario specs,
and the signed distance of points to them with its gradient, in numpy and CasADi.

The MPCs linearise these distances each step; the simulator measures the true distance with PyBullet's
closest points, and the tests compare the two.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

if TYPE_CHECKING:
    from harmony_cli.scenario.world import ObstacleSpec, TableSpec


@dataclass(frozen=True)
class Shape:
    """An obstacle's geometry: `kind` box | cylinder (vertical axis) | sphere, centred at `centre`, turned by `yaw`
    about z; `half` = half extents (box), (radius, radius, half height) (cylinder) or (radius,) * 3 (sphere)."""

    kind: str
    centre: np.ndarray
    yaw: float
    half: np.ndarray

    def grown(self, radius: float) -> Shape:
        """This shape grown sideways (x, y) by `radius` (a sphere in every direction)."""
        grow = np.full(3, radius) if self.kind == "sphere" else np.array([radius, radius, 0.0])
        return Shape(self.kind, self.centre, self.yaw, self.half + grow)

    def corners(self) -> np.ndarray:
        """A box's four corners in plan view (4, 2), counter-clockwise."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * self.half[:2]
        return self.centre[:2] + local @ np.array([[c, s], [-s, c]])

    def _to_local(self, points: np.ndarray) -> np.ndarray:
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        d = np.atleast_2d(points) - self.centre
        return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)

    def _to_world(self, vectors: np.ndarray) -> np.ndarray:
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return np.stack(
            [c * vectors[:, 0] - s * vectors[:, 1], s * vectors[:, 0] + c * vectors[:, 1], vectors[:, 2]], axis=1
        )

    def distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (n,) of points (n, 3) to the surface (negative inside) and its gradient (n, 3)."""
        local = self._to_local(points)
        if self.kind == "sphere":
            d = np.linalg.norm(local, axis=1)
            return d - self.half[0], self._to_world(local / np.maximum(d, 1e-12)[:, None])
        if self.kind == "cylinder":  # a box in (radial, z) coordinates
            radial = np.linalg.norm(local[:, :2], axis=1)
            unit = local[:, :2] / np.maximum(radial, 1e-12)[:, None]
            d2, g2 = _box_distance(np.stack([radial, local[:, 2]], axis=1), self.half[[0, 2]])
            grad = np.column_stack([unit * g2[:, :1], g2[:, 1]])
            return d2, self._to_world(grad)
        d, grad = _box_distance(local, self.half)
        return d, self._to_world(grad)


def obstacle_shape(spec: ObstacleSpec) -> Shape:
    """The shape of a scenario obstacle (ObstacleSpec) where it is at t = 0."""
    half = np.asarray(spec.size, dtype=float) / 2
    if spec.shape == "sphere":
        half = np.full(3, half[0])
    return Shape(spec.shape, np.asarray(spec.position, dtype=float), np.deg2rad(spec.yaw_deg), half)


LEG = 0.05  # [m] square table legs, inset by one leg width from the corners


def table_shape(spec: TableSpec) -> Shape:
    """A table's (TableSpec) outline: a block from the floor to its top (for plots)."""
    half = np.array([spec.top[0] / 2, spec.top[1] / 2, spec.height / 2])
    return Shape("box", np.array([*spec.position, spec.height / 2]), np.deg2rad(spec.yaw_deg), half)


def table_top(spec: TableSpec) -> Shape:
    """A table's top, the slab a robot's trunk (not its lower base) must stay out from under."""
    half = np.array([spec.top[0] / 2, spec.top[1] / 2, spec.thickness / 2])
    return Shape("box", np.array([*spec.position, spec.height - half[2]]), np.deg2rad(spec.yaw_deg), half)


def table_legs(spec: TableSpec) -> list[Shape]:
    """The four legs of a table (TableSpec): what a base (lower than the top) must stay out of; it may pass
    under the top."""
    yaw, half_height = np.deg2rad(spec.yaw_deg), (spec.height - spec.thickness) / 2
    c, s = np.cos(yaw), np.sin(yaw)
    legs = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            x, y = sx * (spec.top[0] / 2 - LEG), sy * (spec.top[1] / 2 - LEG)
            centre = np.array([spec.position[0] + c * x - s * y, spec.position[1] + s * x + c * y, half_height])
            legs.append(Shape("box", centre, yaw, np.array([LEG / 2, LEG / 2, half_height])))
    return legs


def table_top_pose(spec: TableSpec) -> tuple[np.ndarray, float]:
    """Position of a table's top surface centre and its yaw (what relative targets are measured from)."""
    return np.array([*spec.position, spec.height]), float(np.deg2rad(spec.yaw_deg))


def _box_distance(local: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance to an axis-aligned box centred at 0 and its gradient, in any dimension."""
    excess = np.abs(local) - half
    outside = np.maximum(excess, 0.0)
    d_out = np.linalg.norm(outside, axis=1)
    inside = d_out == 0.0
    grad = np.sign(local) * outside / np.maximum(d_out, 1e-12)[:, None]
    d = d_out.copy()
    if inside.any():  # nearest face: the axis with the smallest margin
        axis = np.argmax(excess[inside], axis=1)
        d[inside] = excess[inside, axis]
        g = np.zeros((inside.sum(), local.shape[1]))
        g[np.arange(axis.size), axis] = np.where(local[inside, axis] >= 0, 1.0, -1.0)
        grad[inside] = g
    return d, grad


def symbolic_distance(kind: str, half: np.ndarray, centre, yaw, point, planar: bool = False):
    """Signed distance of a CasADi point (3,) to a shape whose centre (3,) and yaw may be symbols: the same
    function as Shape.distance; `planar` measures in x, y only (a base footprint against a vertical shape)."""
    return _local_distance(kind, half, centre, cs.cos(yaw), cs.sin(yaw), point, planar)


def symbolic_distances(kind: str, half: np.ndarray, centre, yaw, points: list) -> list:
    """symbolic_distance of each of many points (3-D), the shape's turn worked out once for all of them."""
    c, s = cs.cos(yaw), cs.sin(yaw)
    return [_local_distance(kind, half, centre, c, s, point, False) for point in points]


def _local_distance(kind: str, half: np.ndarray, centre, c, s, point, planar: bool):
    """symbolic_distance with the cosine and sine of the shape's yaw given."""
    d = point - centre
    local = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]]
    if kind == "sphere":
        squares = local[0] ** 2 + local[1] ** 2 + (0 if planar else local[2] ** 2)
        return cs.sqrt(squares + 1e-12) - half[0]
    if kind == "cylinder":
        coords, halves = [cs.sqrt(local[0] ** 2 + local[1] ** 2 + 1e-12)], [half[0]]
    else:
        coords, halves = [cs.fabs(local[0]), cs.fabs(local[1])], [half[0], half[1]]
    if not planar:
        coords, halves = coords + [cs.fabs(local[2])], halves + [half[2]]
    excess = [a - b for a, b in zip(coords, halves)]
    outside = cs.sqrt(sum(cs.fmax(e, 0) ** 2 for e in excess) + 1e-12)
    inside = cs.fmin(excess[0] if len(excess) == 1 else cs.mmax(cs.vertcat(*excess)), 0)
    return outside + inside
