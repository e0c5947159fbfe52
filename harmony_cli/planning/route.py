"""A planar route around obstacles: the shortest path in the plane between two points that keeps out of every
obstacle grown by a radius, on a visibility graph.

Why a visibility graph: in the plane, the shortest path among convex obstacles runs straight between their
corners, so the graph of mutually visible corners (plus the two ends) holds it exactly for the polygons used, and
with a handful of obstacles it is a few hundred segment tests (about a millisecond), no grid resolution to choose
and no sampling to seed. Round shapes become circumscribed polygons (the route keeps at least the radius away).

The task-space planner uses it as the homotopy of its local SQP (which side of each obstacle to pass), not as the
path itself: the SQP refines the route with the true clearances, speed bounds and the hands' geometry.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning.visibility import OUTSET, Polygon, corner_graph, inside, polygon_of, tangent, visible

SIDES = 16  # polygon sides of a grown round shape or corner


@dataclass(frozen=True)
class Route:
    points: np.ndarray  # (n, 2) from start to goal, corners in between
    length: float  # [m]

    def at(self, s: np.ndarray) -> np.ndarray:
        """Points (len(s), 2) at arc-length fractions s in [0, 1]."""
        along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))]
        if along[-1] <= 0.0:
            return np.repeat(self.points[:1], len(s), axis=0)
        distance = np.clip(s, 0.0, 1.0) * along[-1]
        return np.column_stack([np.interp(distance, along, self.points[:, i]) for i in (0, 1)])


def footprint(shape: Shape, radius: float) -> np.ndarray:
    """The plan-view outline (k, 2) of `shape` grown by `radius`, counter-clockwise, containing the true one;
    read-only (a route of a run asks for the same few outlines at every re-plan: each is computed once)."""
    key = (shape.kind, tuple(shape.centre.tolist()), float(shape.yaw), tuple(shape.half.tolist()), float(radius))
    return _outline(*key)


@lru_cache(maxsize=256)
def _outline(kind: str, centre: tuple, yaw: float, half: tuple, radius: float) -> np.ndarray:
    angles = 2 * np.pi * (np.arange(SIDES) + 0.5) / SIDES
    circumscribed = np.column_stack([np.cos(angles), np.sin(angles)]) / np.cos(np.pi / SIDES)
    shape = Shape(kind, np.array(centre), yaw, np.array(half))
    if kind in ("cylinder", "sphere"):
        outline = shape.centre[:2] + (shape.half[0] + radius) * circumscribed
    else:
        outline = _convex_hull((shape.corners()[:, None, :] + radius * circumscribed[None]).reshape(-1, 2))
    outline.flags.writeable = False
    return outline


def plan_route(start: np.ndarray, goal: np.ndarray, outlines: list[np.ndarray]) -> Route | None:
    """Shortest path from `start` to `goal` (2,) outside the convex `outlines` (counter-clockwise (k, 2) each).
    An end inside an outline leaves it by the nearest way out (e.g. hands over a table's edge: out over that
    edge) and the rest of the path keeps out of it; None if the ends are not connected."""
    start, goal = np.asarray(start, float)[:2], np.asarray(goal, float)[:2]
    polygons = [polygon_of(o) for o in outlines]
    first, last = _way_out(start, polygons), _way_out(goal, polygons)
    kept = np.array([not (inside(p, first) or inside(p, last)) for p in polygons], dtype=bool)
    blocking = [p for p, k in zip(polygons, kept) if k]  # one holding an end is left by the way out
    if _direct(first, last, blocking):  # the segment is the shortest path: no graph
        return _route(np.vstack([start, first, last, goal]))
    nodes = np.vstack([first, last, *(p.nodes for p in blocking)])
    i, j = _end_pairs(len(nodes))  # the pairs with an end; those between corners come made (visibility.py)
    keep = np.flatnonzero(tangent(nodes, i, j, blocking))
    i, j = i[keep], j[keep]
    seen = visible(nodes, i, j, blocking)
    corner_rows, corner_columns = corner_graph(polygons).edges(kept)
    rows, columns = np.r_[i[seen], corner_rows], np.r_[j[seen], corner_columns]
    lengths = np.maximum(np.linalg.norm(nodes[rows] - nodes[columns], axis=1), 1e-12)
    # compressed rows built directly (the pairs come row by row, columns rising): the COO path's arrays, less work
    starts = np.searchsorted(rows, np.arange(len(nodes) + 1)).astype(np.int32)
    weights = csr_matrix((lengths, columns.astype(np.int32), starts), shape=(len(nodes), len(nodes)))
    distances, previous = dijkstra(weights, directed=False, indices=0, return_predecessors=True)
    if not np.isfinite(distances[1]):
        return None
    path, node = [1], 1
    while node != 0:
        node = int(previous[node])
        path.append(node)
    return _route(np.vstack([start, nodes[path[::-1]], goal]))


def _direct(first: np.ndarray, last: np.ndarray, blocking: list[Polygon]) -> bool:
    """Whether the segment `first` - `last` enters none of the `blocking` outlines."""
    return bool(visible(np.vstack([first, last]), _ENDS[0], _ENDS[1], blocking)[0])


_ENDS = (np.array([0]), np.array([1]))


def _route(points: np.ndarray) -> Route:
    """The route through `points` (n, 2), a point repeated once (an end already out of every outline)."""
    points = points[np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-12]]
    return Route(points, float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()))


@lru_cache(maxsize=64)
def _end_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs of n nodes with an end (node 0 or 1), row by row with the columns rising, read-only."""
    i, j = np.r_[np.zeros(n - 1, dtype=int), np.ones(n - 2, dtype=int)], np.r_[np.arange(1, n), np.arange(2, n)]
    i.flags.writeable = j.flags.writeable = False
    return i, j


def _way_out(point: np.ndarray, polygons: list[Polygon]) -> np.ndarray:
    """`point`, or, inside an outline, the nearest point just outside it (one outline: the first holding it)."""
    for polygon in polygons:
        if inside(polygon, point):
            outline, edges = polygon.outline, polygon.edges
            along = np.clip(np.sum((point - outline) * edges, axis=1) / np.sum(edges * edges, axis=1), 0.0, 1.0)
            feet = outline + along[:, None] * edges
            foot = feet[np.argmin(np.linalg.norm(feet - point, axis=1))]
            away = foot - point
            return foot + OUTSET * away / max(float(np.linalg.norm(away)), 1e-12)
    return point


def _convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise hull (Andrew's monotone chain)."""
    pts = sorted(map(tuple, points))

    def half(sequence):
        chain: list[tuple[float, float]] = []
        for p in sequence:
            while len(chain) >= 2 and _cross(chain[-2], chain[-1], p) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
