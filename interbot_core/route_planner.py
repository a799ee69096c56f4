"""Routes over the topological map: Floyd-Warshall, path reconstruction and start-node choice.

* :func:`floyd_warshall` is thesis Algorithm 1 (§3.4, Floyd 1962): all-pairs shortest distances
  ``dist[u][v]`` and the shortest-path trees as a next-hop matrix ``path[u][v]`` (the node after
  ``u`` on a shortest path to ``v``). The O(N^3) triple loop runs in compiled code
  (``scipy.sparse.csgraph.floyd_warshall``); a readable reference lives in the tests.
* :func:`shortest_path` is thesis Algorithm 2: follow ``path[u][v]`` from ``u`` until ``v``.
* :meth:`RoutePlanner.choose_start_node` is the start-node choice of ``robotMovement()``
  (thesis §5.3.5, Algorithm 5, Fig. 5.11): compare the node closest to the robot with its
  neighbour closest to the robot, and start from the one with the shorter total
  ``|robot - start| + dist[start][goal]``, so the robot never drives back to a node behind it.
* :meth:`RoutePlanner.tour_order` is the guided-tour ring buffer (§5.3.5): every tour node in id
  order, starting at the tour node closest to the robot and wrapping around.

Arcs are undirected. Node poses are in the ``map`` frame [m, rad].
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse.csgraph import csgraph_from_dense
from scipy.sparse.csgraph import floyd_warshall as _scipy_floyd_warshall

from interbot_core.geometry import Pose2D
from interbot_core.topological_map import TopologicalMap

logger = logging.getLogger(__name__)

NO_HOP = -1  # next_hop entry for "v is unreachable from u"
DEFAULT_APPROACH_TOLERANCE = 1.0  # [m] intermediate goals count as reached inside this radius


class RoutePlanningError(ValueError):
    """No route exists (disconnected nodes, no tour stops); the message names the nodes."""


@dataclass(frozen=True)
class Route:
    """A route along topological nodes.

    ``waypoints[i]`` is the pose of node ``node_ids[i]``; the last waypoint carries the goal
    node's arrival yaw, intermediate waypoints face the next waypoint (direction of travel,
    their orientation is never checked). ``length`` [m] = robot to first waypoint + the arcs.
    """

    node_ids: tuple[int, ...]
    waypoints: tuple[Pose2D, ...]
    length: float  # [m]

    def __post_init__(self) -> None:
        if not self.node_ids or len(self.node_ids) != len(self.waypoints):
            raise ValueError("a Route needs one waypoint per node id, at least one")

    @property
    def goal(self) -> int:
        """The final node id."""
        return self.node_ids[-1]


def floyd_warshall(
    n: int, weighted_arcs: Iterable[tuple[int, int, float]]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """All-pairs shortest paths over ``n`` nodes and undirected arcs ``(u, v, w)`` (Algorithm 1).

    Initialise ``dist(u,v) = w(u,v)``, ``path(u,v) = v`` for every arc, then relax
    ``dist(i,j) > dist(i,k) + dist(k,j)`` for every intermediate node k. Returns ``dist``
    (``inf`` where unreachable, 0 on the diagonal) and ``next_hop`` with ``next_hop[u, v]`` the
    node after ``u`` on a shortest path to ``v`` (``u`` when u == v, :data:`NO_HOP` when
    unreachable). Parallel arcs keep the lightest; zero-weight arcs are real arcs.
    """
    if n <= 0:
        raise ValueError(f"floyd_warshall needs at least one node, got n={n}")
    dense = np.full((n, n), np.inf)
    for u, v, w in weighted_arcs:
        if not (0 <= u < n and 0 <= v < n):
            raise ValueError(f"arc ({u}, {v}) has an endpoint outside nodes 0..{n - 1}")
        if not (math.isfinite(w) and w >= 0.0):
            raise ValueError(f"arc ({u}, {v}) weight must be finite and >= 0, got {w!r}")
        if u != v and w < dense[u, v]:
            dense[u, v] = dense[v, u] = w
    graph = csgraph_from_dense(dense, null_value=np.inf)
    dist, pred = _scipy_floyd_warshall(graph, directed=False, return_predecessors=True)
    # scipy's pred[s, t] is the node before t on the path s -> t. Undirected, so the node after
    # u on the way to v is the node before u on the way back from v: next_hop[u, v] = pred[v, u].
    # All hops of one query then follow the single shortest-path tree rooted at v.
    next_hop = np.asarray(pred.T, dtype=np.int64)
    next_hop[next_hop < 0] = NO_HOP
    np.fill_diagonal(next_hop, np.arange(n))
    return np.asarray(dist, dtype=np.float64), next_hop


def shortest_path(next_hop: npt.NDArray[np.int64], u: int, v: int) -> list[int]:
    """The node sequence from ``u`` to ``v`` (both included), thesis Algorithm 2.

    ``sp = [u]; while u != v: u = path(u, v); sp.append(u)``. Raises :class:`RoutePlanningError`
    when ``v`` cannot be reached from ``u``.
    """
    if next_hop[u, v] == NO_HOP:
        raise RoutePlanningError(f"node {v} cannot be reached from node {u}: no chain of arcs")
    sp = [u]
    while u != v:
        u = int(next_hop[u, v])
        sp.append(u)
        if len(sp) > next_hop.shape[0]:  # only possible with a corrupted matrix
            raise RoutePlanningError(f"next-hop matrix loops between {sp[0]} and {v}")
    return sp


class RoutePlanner:
    """All-pairs shortest routes of one :class:`TopologicalMap`, precomputed at construction."""

    def __init__(self, topo: TopologicalMap) -> None:
        self.topo = topo
        self.dist, self.next_hop = floyd_warshall(len(topo.nodes), topo.weighted_arcs())
        if not np.isfinite(self.dist).all():
            unreachable = int(np.argmax(~np.isfinite(self.dist[0])))
            logger.warning(
                "%s: the topological map is not connected (node %d is unreachable from 0)",
                topo.source,
                unreachable,
            )

    def distance(self, u: int, v: int) -> float:
        """Graph distance between two nodes [m] (``inf`` when unreachable)."""
        self.topo.node(u, "start")
        self.topo.node(v, "goal")
        return float(self.dist[u, v])

    def shortest_path(self, u: int, v: int) -> list[int]:
        """Node ids of a shortest route from ``u`` to ``v`` (Algorithm 2)."""
        self.topo.node(u, "start")
        self.topo.node(v, "goal")
        try:
            return shortest_path(self.next_hop, u, v)
        except RoutePlanningError as exc:
            raise RoutePlanningError(
                f"{self.topo.source}: no route from node {u} ({self.topo.nodes[u].name}) to "
                f"node {v} ({self.topo.nodes[v].name}): add an arc joining them"
            ) from exc

    def choose_start_node(self, pose: Pose2D, goal: int) -> int:
        """The node to start from (thesis Algorithm 5, Fig. 5.11).

        ``closest`` is the node nearest the robot, ``other`` its neighbour nearest the robot;
        ``dist1 = |robot - closest| + D[closest][goal]``, ``dist2 = |robot - other| +
        D[other][goal]``; start at ``closest`` if ``dist1 <= dist2`` (ties keep the closest
        node), else at ``other``.
        """
        self.topo.node(goal, "goal")
        closest = self.topo.nearest_node(pose.x, pose.y)
        neighbours = self.topo.neighbours(closest)
        if not neighbours:
            return closest
        other = min(neighbours, key=lambda i: (self._robot_distance(pose, i), i))
        dist1 = self._robot_distance(pose, closest) + float(self.dist[closest, goal])
        dist2 = self._robot_distance(pose, other) + float(self.dist[other, goal])
        return closest if dist1 <= dist2 else other

    def plan(
        self,
        pose: Pose2D,
        goal: int,
        *,
        skip_start_within: float = DEFAULT_APPROACH_TOLERANCE,
    ) -> Route:
        """Route from the robot to ``goal``: Algorithm 5's start node, then Algorithm 2.

        The start node is dropped when the robot is already within ``skip_start_within`` [m]
        of it and it is not the goal: it would count as reached at once, and sending it to the
        robot's local planner could make it turn back to a point it is standing on. Pass 0 to
        always keep it.
        """
        start = self.choose_start_node(pose, goal)
        node_ids = self.shortest_path(start, goal)
        if len(node_ids) > 1 and self._robot_distance(pose, start) < skip_start_within:
            node_ids = node_ids[1:]
        return self.route_through(node_ids, pose)

    def route_through(self, node_ids: list[int] | tuple[int, ...], pose: Pose2D) -> Route:
        """Build a :class:`Route` visiting ``node_ids`` in order, starting from ``pose``."""
        nodes = [self.topo.node(i) for i in node_ids]
        waypoints: list[Pose2D] = []
        for here, there in itertools.pairwise(nodes):
            heading = math.atan2(there.pose.y - here.pose.y, there.pose.x - here.pose.x)
            waypoints.append(Pose2D(here.pose.x, here.pose.y, heading))
        waypoints.append(nodes[-1].pose)
        length = pose.distance_to(nodes[0].pose) + sum(
            float(self.dist[a, b]) for a, b in itertools.pairwise(node_ids)
        )
        return Route(tuple(node_ids), tuple(waypoints), length)

    def tour_order(self, pose: Pose2D) -> list[int]:
        """Guided-tour stops: every ``tour: true`` node in id order, read from a ring buffer
        starting at the tour node closest to the robot (thesis §5.3.5, GuidedBuffer)."""
        stops = [node.id for node in self.topo.tour_nodes()]
        if not stops:
            raise RoutePlanningError(
                f"{self.topo.source}: no node has 'tour: true', so there is no guided tour"
            )
        first = min(range(len(stops)), key=lambda k: (self._robot_distance(pose, stops[k]), k))
        return stops[first:] + stops[:first]

    def _robot_distance(self, pose: Pose2D, node_id: int) -> float:
        return pose.distance_to(self.topo.nodes[node_id].pose)
