"""Which straight segments keep out of a set of convex outlines: the edges of route.py's visibility graph.

It runs inside a control step (a phase's first route), where numpy costs more per call than per element: each
outline's geometry is computed once (a run's outlines are cached, route.footprint), and only segments that could
be on a shortest path are tested: those tangent to the outline at each corner they join (the neighbouring corners
on one side of the line; a shortest path among convex obstacles bends round their corners, so it keeps to these).

The edges between the outlines' own corners are made once per set of outlines (CornerGraph). A route's graph
(route.py) joins its two ends and the corners of every outline in the way. Between one route and the next of a run
only the ends move: the outlines (static obstacles and tables, each grown) stay. So the corner pairs' tests (tangent
at both corners, entering no outline) are made once for all the outlines, before the loop (plan_seed.warm_outlines),
and a route through some of them (those not holding an end) keeps the pairs whose corners are both on those and that
enter none of them: inside the control step only the pairs with an end are tested. The edges are the ones the
route's own tests give, so the route is the same to the bit."""

from __future__ import annotations

from collections.abc import Callable
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


def by_identity(cache: dict, objects: tuple, make: Callable, limit: int):
    """make(objects), kept in `cache` under the objects' ids while its entry lives (the entry holds them: no id is
    reused meanwhile); the cache starts again at `limit` entries (many scenes in one process) rather than grow."""
    key = tuple(map(id, objects))
    found = cache.get(key)
    if found is None or any(a is not b for a, b in zip(found[0], objects)):
        if len(cache) >= limit:
            cache.clear()
        found = cache[key] = (objects, make(*objects))
    return found[1]


_POLYGONS: dict[tuple[int], tuple] = {}


def polygon_of(outline: np.ndarray) -> Polygon:
    """`outline`'s geometry, made once while that outline lives."""
    return by_identity(_POLYGONS, (outline,), Polygon.of, 1024)


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
    if not polygons:
        return np.ones(len(i), dtype=bool)
    return np.logical_not(entering(stack_of(polygons), nodes[i], nodes[j]).any(axis=1))


@dataclass(frozen=True)
class Stack:
    """Polygons' arrays side by side, so that segments are tested against all of them at once: the edges' normals
    and the extents along them (`low`, `high`), the outlines' corners, where each polygon's edges and corners
    begin (`starts`: a polygon has as many of each), the bounding boxes (`box_low`, `box_high`: (polygons, 2))."""

    normals: np.ndarray
    low: np.ndarray
    high: np.ndarray
    corners: np.ndarray
    starts: np.ndarray
    box_low: np.ndarray
    box_high: np.ndarray
    JOINED = ("normals", "low", "high", "outline")  # the polygons' arrays joined into the first four fields

    @classmethod
    def of(cls, *polygons: Polygon) -> Stack:
        starts = np.r_[0, np.cumsum([len(p.outline) for p in polygons])[:-1]]
        normals, low, high, corners = (np.concatenate([getattr(p, k) for p in polygons]) for k in cls.JOINED)
        boxes = np.array([p.limits for p in polygons])  # (polygons, low | high, xy)
        return cls(normals, low, high, corners, starts, boxes[:, 0], boxes[:, 1])


_STACKS: dict[tuple[int, ...], tuple] = {}


def stack_of(polygons: list[Polygon]) -> Stack:
    """These `polygons` side by side (in this order), made once while they live."""
    return by_identity(_STACKS, tuple(polygons), Stack.of, 256)


def entering(stack: Stack, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(segments, polygons): whether each segment a[n]-b[n] ((n, 2) each) enters the interior of each outline
    (separating axes: the outline's edges' normals and the segment's; touching an edge or a corner is not entering;
    a segment whose bounding box misses the outline's is not tested). Products written out, not matrix products:
    BLAS rounds a @ N.T differently for different shapes, and a pair's answer must not depend on its company."""
    low, high = np.minimum(a, b), np.maximum(a, b)
    overlap = (high[:, None, :] > stack.box_low).all(axis=2) & (low[:, None, :] < stack.box_high).all(axis=2)
    normals = stack.normals
    pa = a[:, :1] * normals[:, 0] + a[:, 1:] * normals[:, 1]  # (n, edges)
    pb = b[:, :1] * normals[:, 0] + b[:, 1:] * normals[:, 1]
    apart_on = (np.maximum(pa, pb) <= stack.low + TOUCH) | (np.minimum(pa, pb) >= stack.high - TOUCH)
    apart = np.logical_or.reduceat(apart_on, stack.starts, axis=1)
    across = np.column_stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]])  # the segments' own normals
    length = np.sqrt(across[:, 0] * across[:, 0] + across[:, 1] * across[:, 1])
    across = across / np.maximum(length, 1e-15)[:, None]
    own = across[:, :1] * stack.corners[:, 0] + across[:, 1:] * stack.corners[:, 1]  # (n, corners)
    level = (a[:, 0] * across[:, 0] + a[:, 1] * across[:, 1])[:, None]  # both ends project here
    own_low, own_high = np.minimum.reduceat(own, stack.starts, axis=1), np.maximum.reduceat(own, stack.starts, axis=1)
    beside = ((level <= own_low + TOUCH) | (level >= own_high - TOUCH)) & (length > 1e-15)[:, None]
    return overlap & ~(apart | beside)


ENDS = 2  # a route's graph numbers its two ends first, then the corners


@dataclass(frozen=True)
class CornerGraph:
    """Of the corner pairs tangent at both corners, (i, j) numbered as a graph of all the polygons (ENDS, then each
    polygon's nodes in turn), the polygon holding each corner (`owner`, from ENDS on) and, per pair and polygon,
    whether the pair enters it."""

    i: np.ndarray
    j: np.ndarray
    owner: np.ndarray
    enters: np.ndarray  # (pairs, polygons)

    @classmethod
    def of(cls, *polygons: Polygon) -> CornerGraph:
        sizes = [len(p.nodes) for p in polygons]
        nodes = np.vstack([np.zeros((ENDS, 2)), *(p.nodes for p in polygons)])
        i, j = np.triu_indices(sum(sizes), k=1)
        i, j = i + ENDS, j + ENDS
        keep = np.flatnonzero(tangent(nodes, i, j, list(polygons)))
        i, j = i[keep], j[keep]
        enters = entering(stack_of(list(polygons)), nodes[i], nodes[j]) if polygons else np.zeros((0, 0), dtype=bool)
        return cls(i, j, np.repeat(np.arange(len(polygons)), sizes), enters)

    def edges(self, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The visible corner pairs (rows rising, then columns) of a graph of the `kept` polygons (bool mask) only,
        numbered as that graph's nodes: ENDS, then the kept polygons' nodes in turn."""
        on_kept = kept[self.owner]
        seen = on_kept[self.i - ENDS] & on_kept[self.j - ENDS] & ~self.enters[:, kept].any(axis=1)
        renumbered = np.r_[np.arange(ENDS), ENDS - 1 + np.cumsum(on_kept)]  # monotone: the order holds
        return renumbered[self.i[seen]], renumbered[self.j[seen]]


_GRAPHS: dict[tuple[int, ...], tuple] = {}


def corner_graph(polygons: list[Polygon]) -> CornerGraph:
    """The graph of these `polygons` (in this order), made once while they live."""
    return by_identity(_GRAPHS, tuple(polygons), CornerGraph.of, 64)
