"""The planar route around obstacles (visibility graph) against the analytic shortest path and the shapes' own
signed distances."""

from __future__ import annotations

import numpy as np

from harmony_cli.maths.shapes import Shape
from harmony_cli.planning import route, visibility
from harmony_cli.planning.route import SIDES, footprint, plan_route


def _cylinder(x: float, y: float, radius: float) -> Shape:
    return Shape("cylinder", np.array([x, y, 1.0]), 0.0, np.array([radius, radius, 1.0]))


def _clearance(route, shape: Shape) -> float:
    points = route.at(np.linspace(0.0, 1.0, 2000))
    return float(shape.distance(np.column_stack([points, np.full(len(points), 1.0)]))[0].min())


def test_an_unobstructed_route_is_the_straight_segment():
    route = plan_route(np.zeros(2), np.array([2.0, 0.0]), [footprint(_cylinder(1.0, 1.0, 0.3), 0.2)])
    assert route is not None and len(route.points) == 2 and route.length == 2.0


def test_the_route_round_a_circle_is_the_tangent_arc_tangent_path_to_within_the_polygon():
    # start and goal 1 m either side of a 0.5 m circle: shortest path = 2 tangents + the arc between them
    d, r = 1.0, 0.5
    route = plan_route(np.array([-d, 0.0]), np.array([d, 0.0]), [footprint(_cylinder(0.0, 0.0, 0.3), 0.2)])
    tangent, arc = np.sqrt(d * d - r * r), r * (np.pi - 2 * np.arccos(r / d))
    exact = 2 * tangent + arc
    assert route is not None
    assert exact - 1e-9 <= route.length <= exact / np.cos(np.pi / SIDES)
    assert _clearance(route, _cylinder(0.0, 0.0, 0.3)) >= 0.2 - 1e-6


def test_the_route_keeps_a_boxs_grown_outline_clear_and_passes_between_two_obstacles_when_the_gap_allows():
    crate = Shape("box", np.array([1.0, 0.3, 0.5]), np.deg2rad(30), np.array([0.2, 0.3, 0.5]))
    post = _cylinder(1.0, -0.7, 0.2)
    outlines = [footprint(crate, 0.15), footprint(post, 0.15)]
    route = plan_route(np.zeros(2), np.array([2.0, 0.0]), outlines)
    assert route is not None
    assert _clearance(route, crate) >= 0.15 - 1e-6 and _clearance(route, post) >= 0.15 - 1e-6
    y = route.at(np.linspace(0, 1, 500))[:, 1]
    assert y.min() > -0.7 and y.max() < 0.3  # through the gap, not round the outside of either


def test_a_start_walled_in_has_no_route():
    walls = [
        Shape("box", np.array([x, y, 0.5]), 0.0, np.array([hx, hy, 0.5]))
        for x, y, hx, hy in (
            (0.0, 1.0, 1.1, 0.05),
            (0.0, -1.0, 1.1, 0.05),
            (1.0, 0.0, 0.05, 1.1),
            (-1.0, 0.0, 0.05, 1.1),
        )
    ]
    assert plan_route(np.zeros(2), np.array([3.0, 0.0]), [footprint(w, 0.1) for w in walls]) is None


def test_an_outline_holding_the_start_is_left_by_the_nearest_way_out_and_never_entered_again():
    # hands over a table's edge (inside its grown outline) going to the far side of the table: out, then round
    table = Shape("box", np.array([0.0, 0.0, 0.4]), 0.0, np.array([1.0, 0.4, 0.4]))
    route = plan_route(np.array([0.0, 0.5]), np.array([0.0, -1.2]), [footprint(table, 0.3)])
    assert route is not None and np.allclose(route.points[1], [0.0, 0.7], atol=1e-5)  # straight out over the edge
    rest = route.at(np.linspace(0.0, 1.0, 2000))[route.at(np.linspace(0.0, 1.0, 2000))[:, 1] < 0.7 - 1e-4]
    rest = rest[np.abs(rest[:, 0]) > 1e-3]  # past the way out
    assert _clearance_of(rest, table) >= 0.3 - 1e-6


def _clearance_of(points: np.ndarray, shape: Shape) -> float:
    return float(shape.distance(np.column_stack([points, np.full(len(points), shape.centre[2])]))[0].min())


def test_an_outline_asked_for_again_is_the_one_computed_first_and_cannot_be_changed():
    box = Shape("box", np.array([1.0, 2.0, 0.5]), 0.3, np.array([0.4, 0.2, 0.5]))
    first = footprint(box, 0.25)
    again = footprint(Shape("box", np.array([1.0, 2.0, 0.5]), 0.3, np.array([0.4, 0.2, 0.5])), 0.25)
    assert again is first and not first.flags.writeable
    assert footprint(box, 0.26) is not first  # another radius is another outline


def test_a_route_after_its_outlines_were_warmed_computes_none_of_them_nor_their_geometry_nor_their_graph():
    from harmony_cli.planning.hand_plan import Obstacle
    from harmony_cli.planning.plan_seed import Ground, route_around, warm_outlines

    crate = Obstacle(Shape("box", np.array([2.0, 0.1, 0.6]), 0.2, np.array([0.3, 0.4, 0.6])), 0.35)
    table = Shape("box", np.array([4.0, 0.0, 0.5]), 0.0, np.array([0.4, 0.75, 0.5]))
    ground = Ground([(table, 0.03)], base_radius=0.38)
    warm_outlines([crate], ground)
    computed, geometry = route._outline.cache_info().misses, set(visibility._POLYGONS)
    graphs = set(visibility._GRAPHS)
    hands = lambda x: np.array([[x, 0.15, 1.2], [x, -0.15, 1.2]])
    found = route_around([crate], hands(0.5), hands(3.2), (0.2, 0.15), ground)
    assert found is not None and len(found.points) > 2  # it went round the crate
    assert route._outline.cache_info().misses == computed
    assert set(visibility._POLYGONS) == geometry
    assert set(visibility._GRAPHS) == graphs


def test_keeping_only_segments_tangent_at_their_corners_changes_no_route_on_random_scenes(monkeypatch):
    """A shortest path among convex outlines bends round their corners: the full visibility graph finds the same."""
    rng = np.random.default_rng(11)
    scenes = []
    for _ in range(300):
        shapes = []
        for _ in range(int(rng.integers(1, 9))):
            half = np.r_[rng.uniform(0.1, 0.8, 2), 0.5]
            kind = str(rng.choice(["box", "cylinder"]))
            half[1] = half[0] if kind == "cylinder" else half[1]
            shape = Shape(kind, np.r_[rng.uniform(-3, 3, 2), 0.5], float(rng.uniform(-np.pi, np.pi)), half)
            shapes.append(footprint(shape, float(rng.uniform(0.0, 0.5))))
        scenes.append((rng.uniform(-4, 4, 2), rng.uniform(-4, 4, 2), shapes))
    tangent_only = [plan_route(*scene) for scene in scenes]
    every = lambda nodes, i, j, polygons: np.ones(len(i), dtype=bool)  # noqa: E731
    monkeypatch.setattr(route, "tangent", every)
    monkeypatch.setattr(visibility, "tangent", every)
    monkeypatch.setattr(visibility, "_GRAPHS", {})
    full = [plan_route(*scene) for scene in scenes]
    assert sum(r is not None and len(r.points) > 2 for r in full) > 100  # a third and more go round something
    for got, expected in zip(tangent_only, full):
        assert (got is None) == (expected is None)
        if expected is not None:
            np.testing.assert_array_equal(got.points, expected.points)


def test_the_segment_taken_when_clear_is_the_route_the_full_graph_finds_on_random_scenes(monkeypatch):
    """plan_route skips its graph when the segment between the ends (once out of any outline) is clear: the
    shortest path there, as the graph's search finds too."""
    rng = np.random.default_rng(14)
    scenes = []
    for _ in range(300):
        shapes = [footprint(_cylinder(*rng.uniform(-3, 3, 2), float(rng.uniform(0.1, 0.6))), 0.2) for _ in range(3)]
        scenes.append((rng.uniform(-4, 4, 2), rng.uniform(-4, 4, 2), shapes))
    fast = [plan_route(*scene) for scene in scenes]
    monkeypatch.setattr(route, "_direct", lambda first, last, blocking: False)
    full = [plan_route(*scene) for scene in scenes]
    straight = sum(r is not None and len(r.points) == 2 for r in full)
    assert 50 < straight < 250  # both ways are tried
    for got, expected in zip(fast, full):
        assert (got is None) == (expected is None)
        if expected is not None:
            np.testing.assert_allclose(got.points, expected.points, atol=1e-12)
            assert abs(got.length - expected.length) < 1e-9


def test_the_corner_pairs_made_ahead_for_all_outlines_are_those_tested_among_the_outlines_a_route_keeps():
    # corner_graph's edges for a subset of the outlines (those holding no end) against the pairs of the subset's
    # corners tested there (tangent at both corners, entering none of the subset): the same pairs, in the same order
    rng = np.random.default_rng(3)
    for _ in range(200):
        count = int(rng.integers(1, 6))
        shapes = [_cylinder(*rng.uniform(-3, 3, 2), float(rng.uniform(0.1, 0.6))) for _ in range(count)]
        polygons = [visibility.polygon_of(footprint(shape, 0.2)) for shape in shapes]
        kept = rng.uniform(size=len(polygons)) < 0.7
        blocking = [p for p, k in zip(polygons, kept) if k]
        nodes = np.vstack([np.zeros((2, 2)), *(p.nodes for p in blocking)])
        i, j = np.triu_indices(len(nodes), k=1)
        i, j = i[i >= 2], j[i >= 2]
        tangent = visibility.tangent(nodes, i, j, blocking)
        i, j = i[tangent], j[tangent]
        seen = visibility.visible(nodes, i, j, blocking)
        got = visibility.CornerGraph.of(*polygons).edges(kept)
        np.testing.assert_array_equal(got[0], i[seen])
        np.testing.assert_array_equal(got[1], j[seen])


def test_a_route_s_fit_by_the_matrix_built_with_the_planner_equals_numpy_s_least_squares():
    # the planner's control points fitted to a shift at its samples: the pseudo-inverse made once (HandSQP) against
    # np.linalg.lstsq solved each time, as the fit was before
    from harmony_cli.planning.hand_sqp import HandSQP
    from harmony_cli.scenario import PlannerSpec

    sqp = HandSQP(PlannerSpec(), [], 0.0)
    shift = np.random.default_rng(5).normal(size=(len(sqp.s), 2))
    expected = np.linalg.lstsq(sqp.B[:, sqp.free[0]], shift, rcond=None)[0]
    np.testing.assert_allclose(sqp.fit @ shift, expected, atol=1e-12)
