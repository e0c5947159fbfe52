"""The visibility graph's edges between the outlines' own corners, made once per set of outlines.

A route's graph (route.py) joins its two ends and the corners of every outline in the way. Between one route and
the next of a run only the ends move: the outlines (static obstacles and tables, each grown) stay. So the corner
pairs' tests (tangent at both corners, entering no outline) are made once for all the outlines, before the loop
(plan_seed.warm_outlines), and a route through some of them (those not holding an end) keeps the pairs whose
corners are both on those and that enter none of them: inside the control step only the pairs with an end are
tested. The edges are the ones the route's own tests give, so the route is the same to the bit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harmony_cli.planning.visibility import Polygon, by_identity, entering, stack_of, tangent

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
