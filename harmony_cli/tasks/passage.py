"""Whether the base can get from where it starts to a place: a flood fill over the plane of where a disc as wide as
the footprint at its narrowest fits between the standing bodies, each kept at its margin.

A necessary condition, not a plan: a base passes a gap between two bodies only if the gap is at least the
footprint's width across it, and never narrower than its narrowest width; the disc of that width passes every
such gap. A cell is free when the disc, a cell (2 cm) narrower, fits at its centre, so that a gap within a cell of
the limit is judged passable; the fill joins diagonal neighbours, and a goal may be anywhere within the disc's
radius of a filled cell. A footprint whose narrow axis is far off its origin may pass where it cannot. The grid
spans every body with a free ring around them, so a way round the outside of a wall counts."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from harmony_cli.maths.shapes import Shape

CELL = 0.02  # [m] the grid's spacing; gaps within a cell of the limit are judged passable
DIRECTIONS = 180  # directions over a half turn in which the footprint's width is measured


def narrowest_width(circles: np.ndarray) -> float:
    """The footprint's (circles (n, 3): x, y, radius) smallest width over the directions [m]."""
    angles = np.linspace(0.0, np.pi, DIRECTIONS, endpoint=False)
    normals = np.column_stack([np.cos(angles), np.sin(angles)])
    along = circles[:, :2] @ normals.T  # (n, directions)
    radius = circles[:, 2:3]
    return float(((along + radius).max(axis=0) - (along - radius).min(axis=0)).min())


class Passage:
    """The places the base can reach from `start` (x, y) among `blocked` (shape, margin) bodies."""

    def __init__(self, blocked: list[tuple[Shape, float]], circles: np.ndarray, start: np.ndarray, places: np.ndarray):
        self.width = narrowest_width(circles)
        self.radius = 0.5 * self.width
        extents = [np.abs(s.half[:2]).max() * np.sqrt(2) + m for s, m in blocked]
        points = np.vstack([np.atleast_2d(start), places] + [s.centre[None, :2] for s, _ in blocked])
        pad = 2 * self.radius + max(extents, default=0.0) + 2 * CELL
        self.origin = points.min(axis=0) - pad
        shape = np.ceil((points.max(axis=0) + pad - self.origin) / CELL).astype(int) + 1
        free = np.ones(shape, dtype=bool)
        for (body, margin), extent in zip(blocked, extents):  # only the cells the disc could touch it from
            low = np.maximum(np.floor((body.centre[:2] - extent - self.radius - self.origin) / CELL).astype(int), 0)
            high = np.minimum(
                np.ceil((body.centre[:2] + extent + self.radius - self.origin) / CELL).astype(int) + 1, shape
            )
            xs, ys = (self.origin[i] + CELL * np.arange(low[i], high[i]) for i in (0, 1))
            centres = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
            fits = planar_distance(body, centres) - margin >= self.radius - CELL
            free[low[0] : high[0], low[1] : high[1]] &= fits.reshape(len(xs), len(ys))
        labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
        i, j = self._cell(np.atleast_2d(start))
        start_label = int(labels[i[0], j[0]])
        self.reached = None  # a start where the disc does not fit is not judged (everything reaches)
        if start_label:  # every cell within the disc's radius (and a cell) of the filled region
            self.reached = ndimage.distance_transform_edt(labels != start_label) <= self.radius / CELL + 1

    def reaches(self, places: np.ndarray) -> bool:
        """Whether any of `places` (n, 2) is reachable (within the disc's radius of the filled region)."""
        if self.reached is None or len(places) == 0:
            return self.reached is None
        cells = self._cell(places)
        inside = np.all((np.array(cells) >= 0) & (np.array(cells) < np.array(self.reached.shape)[:, None]), axis=0)
        return bool(self.reached[cells[0][inside], cells[1][inside]].any())

    def _cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        index = np.rint((xy - self.origin) / CELL).astype(int)
        return index[:, 0], index[:, 1]


def planar_distance(shape: Shape, xy: np.ndarray) -> np.ndarray:
    """Signed distance in x, y of points to a vertical shape's outline (a sphere as its widest disc)."""
    points = np.column_stack([xy, np.full(len(xy), shape.centre[2])])
    flat = Shape("cylinder" if shape.kind == "sphere" else shape.kind, shape.centre, shape.yaw, shape.half)
    return flat.distance(points)[0]
