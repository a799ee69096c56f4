"""Tests for interbot_core.route_planner: Algorithms 1, 2 and 5 and the guided-tour order."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from interbot_core.route_planner import (
    NO_HOP,
    RoutePlanner,
    RoutePlanningError,
    floyd_warshall,
    shortest_path,
)
from interbot_core.topological_map import TopologicalMap, TopologicalMapError, load_topological_map

FIXTURE = Path(__file__).parent / "data" / "tiny_topo.yaml"


def reference_floyd_warshall(
    n: int, arcs: list[tuple[int, int, float]]
) -> tuple[list[list[float]], list[list[int | None]]]:
    """Thesis Algorithm 1, line by line: dist and path (next hop) matrices."""
    dist = [[math.inf] * n for _ in range(n)]
    path: list[list[int | None]] = [[None] * n for _ in range(n)]
    for i in range(n):
        dist[i][i] = 0.0
        path[i][i] = i
    for u, v, w in arcs:
        for a, b in ((u, v), (v, u)):
            if w < dist[a][b]:
                dist[a][b] = w
                path[a][b] = b
    for k in range(n):
        for i in range(n):
            for j in range(n):
                if dist[i][j] > dist[i][k] + dist[k][j]:
                    dist[i][j] = dist[i][k] + dist[k][j]
                    path[i][j] = path[i][k]
    return dist, path


@st.composite
def connected_graphs(draw: st.DrawFn) -> tuple[int, list[tuple[int, int, float]]]:
    n = draw(st.integers(min_value=1, max_value=9))
    weight = st.floats(min_value=0.0, max_value=50.0, allow_nan=False)
    arcs = [(draw(st.integers(0, v - 1)), v, draw(weight)) for v in range(1, n)]  # spanning tree
    if n > 1:
        extra = draw(
            st.lists(
                st.tuples(st.integers(0, n - 1), st.integers(0, n - 1), weight), max_size=2 * n
            )
        )
        arcs += [(u, v, w) for u, v, w in extra if u != v]
    return n, arcs


@settings(max_examples=150, deadline=None)
@given(connected_graphs())
def test_floyd_warshall_matches_reference_and_paths_are_shortest(
    graph: tuple[int, list[tuple[int, int, float]]],
) -> None:
    n, arcs = graph
    dist, next_hop = floyd_warshall(n, arcs)
    ref_dist, _ = reference_floyd_warshall(n, arcs)
    np.testing.assert_allclose(dist, np.array(ref_dist), rtol=1e-9, atol=1e-9)
    lightest: dict[tuple[int, int], float] = {}
    for u, v, w in arcs:
        for key in ((u, v), (v, u)):
            lightest[key] = min(w, lightest.get(key, math.inf))
    for u in range(n):
        for v in range(n):
            sp = shortest_path(next_hop, u, v)
            assert sp[0] == u and sp[-1] == v
            assert len(set(sp)) == len(sp)  # simple path
            length = sum(lightest[(a, b)] for a, b in itertools.pairwise(sp))
            assert length == pytest.approx(dist[u, v], rel=1e-9, abs=1e-9)


def test_shortest_path_on_small_graph() -> None:
    # square 0-1-2-3-0 with a cheap diagonal 0-2
    dist, next_hop = floyd_warshall(
        4, [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (3, 0, 1.0), (0, 2, 1.5)]
    )
    assert shortest_path(next_hop, 0, 2) == [0, 2]
    assert shortest_path(next_hop, 1, 3) in ([1, 0, 3], [1, 2, 3])
    assert shortest_path(next_hop, 3, 3) == [3]
    assert dist[1, 3] == 2.0


def test_zero_weight_arc_is_an_arc_and_unreachable_raises() -> None:
    dist, next_hop = floyd_warshall(4, [(0, 1, 0.0), (1, 2, 2.0)])
    assert dist[0, 2] == 2.0
    assert next_hop[0, 3] == NO_HOP
    assert math.isinf(dist[0, 3])
    with pytest.raises(RoutePlanningError, match="node 3 cannot be reached from node 0"):
        shortest_path(next_hop, 0, 3)


def test_floyd_warshall_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="at least one node"):
        floyd_warshall(0, [])
    with pytest.raises(ValueError, match=r"outside nodes 0\.\.1"):
        floyd_warshall(2, [(0, 2, 1.0)])
    with pytest.raises(ValueError, match="finite and >= 0"):
        floyd_warshall(2, [(0, 1, -1.0)])


def _line(xs: list[float], arcs: list[list[int]] | None = None) -> TopologicalMap:
    nodes = [{"id": i, "name": f"N{i}", "x": x, "y": 0.0, "yaw": 0.0} for i, x in enumerate(xs)]
    data: dict[str, object] = {"nodes": nodes}
    data["arcs"] = arcs if arcs is not None else [[i, i + 1] for i in range(len(xs) - 1)]
    return TopologicalMap.from_dict(data, source="line.yaml")


def test_choose_start_skips_closest_node_behind_robot() -> None:
    """Thesis Fig. 5.11: the closest node (5) lies behind the robot on the way to goal 4."""
    planner = RoutePlanner(_line([0.0, 10.0, 20.0]))
    robot = Pose2D(3.0, 0.5, 0.0)  # closest is node 0 (3 m), its neighbour 1 is 7 m ahead
    # dist1 = 3.04 + 20 > dist2 = 7.02 + 10: start at node 1, do not drive back to node 0
    assert planner.choose_start_node(robot, 2) == 1
    route = planner.plan(robot, 2)
    assert route.node_ids == (1, 2)
    assert route.length == pytest.approx(math.hypot(7.0, 0.5) + 10.0)
    # towards a goal behind the robot the closest node is the right start
    assert planner.choose_start_node(robot, 0) == 0
    assert planner.plan(robot, 0).node_ids == (0,)


def test_choose_start_keeps_closest_when_it_is_on_the_way() -> None:
    planner = RoutePlanner(_line([0.0, 10.0, 20.0]))
    robot = Pose2D(8.0, 0.0, 0.0)  # closest node 1 (2 m), best neighbour 0 (8 m)
    assert planner.choose_start_node(robot, 2) == 1
    assert planner.plan(robot, 2, skip_start_within=0.0).node_ids == (1, 2)


def test_plan_drops_start_node_the_robot_stands_on() -> None:
    planner = RoutePlanner(_line([0.0, 10.0, 20.0]))
    on_node = Pose2D(10.3, 0.0, 0.0)
    assert planner.plan(on_node, 0).node_ids == (0,)  # start 1 is within 1 m: dropped
    assert planner.plan(on_node, 0, skip_start_within=0.0).node_ids == (1, 0)
    assert planner.plan(on_node, 1).node_ids == (1,)  # the goal itself is never dropped


def test_isolated_closest_node_and_unreachable_goal() -> None:
    planner = RoutePlanner(_line([0.0, 10.0, 30.0], arcs=[[0, 1]]))
    robot = Pose2D(29.0, 0.0, 0.0)
    assert planner.choose_start_node(robot, 0) == 2  # no neighbours: the closest
    with pytest.raises(
        RoutePlanningError, match=r"line.yaml: no route from node 2 \(N2\) to node 0"
    ):
        planner.plan(robot, 0)
    with pytest.raises(TopologicalMapError, match=r"goal 7 is not a node of line\.yaml"):
        planner.plan(robot, 7)


def test_route_waypoints_face_direction_of_travel_and_goal_yaw() -> None:
    topo = load_topological_map(FIXTURE)
    planner = RoutePlanner(topo)
    route = planner.plan(Pose2D(0.0, 0.0, 0.0), 3, skip_start_within=0.0)
    assert route.node_ids == (0, 1, 2, 3)
    yaws = [w.yaw for w in route.waypoints]
    assert yaws[:3] == pytest.approx([0.0, 0.0, math.pi / 2])
    assert route.waypoints[-1] == topo.node(3).pose
    assert route.goal == 3
    assert route.length == pytest.approx(30.0)


def test_fixture_uses_explicit_weight() -> None:
    planner = RoutePlanner(load_topological_map(FIXTURE))
    assert planner.distance(3, 4) == pytest.approx(12.5)
    assert planner.shortest_path(0, 4) == [0, 1, 4]
    assert planner.shortest_path(3, 0) == [3, 2, 1, 0]  # 30 m, vs 3-4-1-0 = 32.5 m


def test_tour_order_is_a_ring_from_the_closest_tour_node() -> None:
    planner = RoutePlanner(load_topological_map(FIXTURE))  # tour nodes 0, 1, 2, 4
    assert planner.tour_order(Pose2D(0.5, 0.0, 0.0)) == [0, 1, 2, 4]
    assert planner.tour_order(Pose2D(19.0, 1.0, 0.0)) == [2, 4, 0, 1]
    # node 3 is not a tour node: the nearest *tour* node (2 at 10 m vs 4 at 10 m, tie -> first)
    assert planner.tour_order(Pose2D(20.0, 10.0, 0.0)) == [2, 4, 0, 1]


def test_no_tour_nodes_is_an_error() -> None:
    planner = RoutePlanner(_line([0.0, 1.0]))
    with pytest.raises(RoutePlanningError, match="no node has 'tour: true'"):
        planner.tour_order(Pose2D(0.0, 0.0, 0.0))
