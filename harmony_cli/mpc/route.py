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

SIDES = 16  # polygon sides of a grown round shape or corner
OUTSET = 1e-6  # [m] corners pushed out so a route along an edge does not count as entering


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
    circumscribed = _unit_ring() / np.cos(np.pi / SIDES)
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
    first, last = _way_out(start, outlines), _way_out(goal, outlines)
    held = [o for o in outlines if _inside(o, first) or _inside(o, last)]  # still inside after the way out
    blocking = [o for o in outlines if not any(o is h for h in held)]
    nodes = np.vstack([first, last, *(_pushed_out(o) for o in blocking)])
    i, j = np.triu_indices(len(nodes), k=1)
    visible, low, high = np.ones(len(i), dtype=bool), np.minimum(nodes[i], nodes[j]), np.maximum(nodes[i], nodes[j])
    for outline in blocking:  # only the segments whose bounding box overlaps the outline's can enter it
        near = np.flatnonzero(
            visible & np.all(high > outline.min(axis=0), axis=1) & np.all(low < outline.max(axis=0), axis=1)
        )
        visible[near] = ~_crosses(outline, nodes[i[near]], nodes[j[near]])
    lengths = np.maximum(np.linalg.norm(nodes[i[visible]] - nodes[j[visible]], axis=1), 1e-12)
    # sparse, as dijkstra stores a dense matrix anyway: the same graph without building the n x n array
    weights = csr_matrix((lengths, (i[visible], j[visible])), shape=(len(nodes), len(nodes)))
    distances, previous = dijkstra(weights, directed=False, indices=0, return_predecessors=True)
    if not np.isfinite(distances[1]):
        return None
    path, node = [1], 1
    while node != 0:
        node = int(previous[node])
        path.append(node)
    points = np.vstack([start, nodes[path[::-1]], goal])
    points = points[np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-12]]  # ends already out
    return Route(points, float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()))


def _way_out(point: np.ndarray, outlines: list[np.ndarray]) -> np.ndarray:
    """`point`, or, inside an outline, the nearest point just outside it (one outline: the first holding it)."""
    for outline in outlines:
        if _inside(outline, point):
            edges = np.diff(outline, axis=0, append=outline[:1])
            along = np.clip(np.sum((point - outline) * edges, axis=1) / np.sum(edges * edges, axis=1), 0.0, 1.0)
            feet = outline + along[:, None] * edges
            foot = feet[np.argmin(np.linalg.norm(feet - point, axis=1))]
            away = foot - point
            return foot + OUTSET * away / max(float(np.linalg.norm(away)), 1e-12)
    return point


def _unit_ring() -> np.ndarray:
    angles = 2 * np.pi * (np.arange(SIDES) + 0.5) / SIDES
    return np.column_stack([np.cos(angles), np.sin(angles)])


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


def _pushed_out(outline: np.ndarray) -> np.ndarray:
    centre = outline.mean(axis=0)
    d = outline - centre
    return outline + OUTSET * d / np.linalg.norm(d, axis=1, keepdims=True)


def _inside(outline: np.ndarray, point: np.ndarray) -> bool:
    edges = np.diff(outline, axis=0, append=outline[:1])
    rel = point - outline
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] > 0))


def _crosses(outline: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether each segment a[n]-b[n] ((n, 2) each) enters the interior of the convex outline (separating axes:
    its edges' normals and the segment's; touching an edge or a corner is not entering)."""
    tol = 1e-9
    edges = np.diff(outline, axis=0, append=outline[:1])
    normals = np.column_stack([edges[:, 1], -edges[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    polygon = outline @ normals.T  # (vertices, edges)
    low, high = polygon.min(axis=0), polygon.max(axis=0)
    pa, pb = a @ normals.T, b @ normals.T  # (n, edges)
    apart = (np.maximum(pa, pb) <= low + tol) | (np.minimum(pa, pb) >= high - tol)
    across = np.column_stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]])  # the segments' own normals
    length = np.linalg.norm(across, axis=1, keepdims=True)
    across = across / np.maximum(length, 1e-15)
    own = (outline @ across.T).T  # (n, vertices)
    level = np.sum(a * across, axis=1)  # both ends project here
    beside = (level <= own.min(axis=1) + tol) | (level >= own.max(axis=1) - tol)
    return ~(apart.any(axis=1) | (beside & (length[:, 0] > 1e-15)))
