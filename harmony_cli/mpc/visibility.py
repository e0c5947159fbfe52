"""Which straight segments keep out of a set of convex outlines: the edges of route.py's visibility graph.

It runs inside a control step (a phase's first route), where numpy costs more per call than per element: each
outline's geometry is computed once (a run's outlines are cached, route.footprint), and only segments that could
be on a shortest path are tested: those tangent to the outline at each corner they join (the neighbouring corners
on one side of the line; a shortest path among convex obstacles bends round their corners, so it keeps to these).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

OUTSET = 1e-6  # [m] corners pushed out so a route along an edge does not count as entering
TOUCH = 1e-9  # [m] separating axes: touching an edge or a corner is not entering
ON_LINE = 1e-5  # [m] a neighbouring corner this near a segment's line counts as on either side (kept: no loss)


@dataclass(frozen=True)
class Polygon:
    """A convex outline (k, 2), counter-clockwise, with what the tests need: its edges (corner k to k + 1), their
    outward unit normals and its extent along each (`low`, `high`), its bounding box as floats (`limits`: low,
    high) and its corners pushed out by OUTSET (the graph's nodes)."""

    outline: np.ndarray
    edges: np.ndarray
    normals: np.ndarray
    low: np.ndarray
    high: np.ndarray
    limits: tuple[tuple[float, float], tuple[float, float]]
    nodes: np.ndarray

    @classmethod
    def of(cls, outline: np.ndarray) -> Polygon:
        edges = np.diff(outline, axis=0, append=outline[:1])
        normals = np.column_stack([edges[:, 1], -edges[:, 0]])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        projected = outline @ normals.T  # (corners, edges)
        d = outline - outline.mean(axis=0)
        nodes = outline + OUTSET * d / np.linalg.norm(d, axis=1, keepdims=True)
        limits = (tuple(outline.min(axis=0).tolist()), tuple(outline.max(axis=0).tolist()))
        return cls(outline, edges, normals, projected.min(axis=0), projected.max(axis=0), limits, nodes)


_POLYGONS: dict[int, Polygon] = {}


def polygon_of(outline: np.ndarray) -> Polygon:
    """`outline`'s geometry, from the cache while that outline lives (held there: its id is not reused)."""
    found = _POLYGONS.get(id(outline))
    if found is None or found.outline is not outline:
        if len(_POLYGONS) >= 1024:  # many scenes in one process: start again rather than grow
            _POLYGONS.clear()
        found = _POLYGONS[id(outline)] = Polygon.of(outline)
    return found


def inside(polygon: Polygon, point: np.ndarray) -> bool:
    """Whether `point` (2,) is strictly inside."""
    (x0, y0), (x1, y1) = polygon.limits
    x, y = float(point[0]), float(point[1])
    if not (x0 < x < x1 and y0 < y < y1):  # strictly inside is strictly within the bounding box: no arrays
        return False
    edges, rel = polygon.edges, point - polygon.outline
    return bool((edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] > 0).all())


def tangent(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, polygons: list[Polygon]) -> np.ndarray:
    """Per pair of `nodes` (the two ends, then each polygon's nodes in turn), whether its line leaves the
    neighbouring corners of each end that is a polygon's corner on one side (within ON_LINE)."""
    before, after = _neighbours(tuple(len(p.nodes) for p in polygons))
    d = nodes[j] - nodes[i]
    length = np.sqrt(np.sum(d * d, axis=1))
    keep = np.ones(len(i), dtype=bool)
    for end in (i, j):
        u, b, a = nodes[end], nodes[before[end]], nodes[after[end]]
        c1 = d[:, 0] * (b[:, 1] - u[:, 1]) - d[:, 1] * (b[:, 0] - u[:, 0])
        c2 = d[:, 0] * (a[:, 1] - u[:, 1]) - d[:, 1] * (a[:, 0] - u[:, 0])
        across = (c1 * c2 < 0.0) & (np.minimum(np.abs(c1), np.abs(c2)) > ON_LINE * length)
        keep &= ~across
    return keep


@lru_cache(maxsize=64)
def _neighbours(sizes: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Each node's neighbouring corners (before, after) on its polygon, the polygons' `sizes` in turn after the two
    ends (each its own neighbour: no test)."""
    own = np.concatenate([[0, 0], *(np.arange(k) for k in sizes)]).astype(int)
    size = np.concatenate([[1, 1], *(np.full(k, k) for k in sizes)]).astype(int)
    start = np.arange(len(own)) - own
    before, after = start + (own - 1) % size, start + (own + 1) % size
    before.flags.writeable = after.flags.writeable = False
    return before, after


def visible(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, polygons: list[Polygon]) -> np.ndarray:
    """Per pair, whether the segment nodes[i] - nodes[j] enters none of the `polygons`."""
    out, a, b = np.ones(len(i), dtype=bool), nodes[i], nodes[j]
    low, high = np.minimum(a, b), np.maximum(a, b)
    for p in polygons:  # only the segments whose bounding box overlaps the outline's can enter it
        (x0, y0), (x1, y1) = p.limits
        overlap = (high[:, 0] > x0) & (high[:, 1] > y0) & (low[:, 0] < x1) & (low[:, 1] < y1)
        near = np.flatnonzero(out & overlap)
        out[near] = ~_crosses(p, a[near], b[near])
    return out


def _crosses(polygon: Polygon, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether each segment a[n]-b[n] ((n, 2) each) enters the interior of the convex outline (separating axes:
    its edges' normals and the segment's; touching an edge or a corner is not entering)."""
    normals = polygon.normals
    pa, pb = a @ normals.T, b @ normals.T  # (n, edges)
    apart = (np.maximum(pa, pb) <= polygon.low + TOUCH) | (np.minimum(pa, pb) >= polygon.high - TOUCH)
    across = np.column_stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]])  # the segments' own normals
    length = np.linalg.norm(across, axis=1, keepdims=True)
    across = across / np.maximum(length, 1e-15)
    own = (polygon.outline @ across.T).T  # (n, vertices)
    level = np.sum(a * across, axis=1)  # both ends project here
    beside = (level <= own.min(axis=1) + TOUCH) | (level >= own.max(axis=1) - TOUCH)
    return ~(apart.any(axis=1) | (beside & (length[:, 0] > 1e-15)))
