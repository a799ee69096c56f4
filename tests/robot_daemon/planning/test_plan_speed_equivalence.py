"""The planner's fast paths equal their plain references, bit for bit (issue 12 speed work).

Each reference is the readable version the fast code replaced (STYLE.md); equality, not
closeness, is asserted: the same costmap, the same A* graph (hence the same routes, ties
included) and the same local-planner distances.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.planning.costmap import Costmap
from robot_daemon.planning.global_planner import (
    _OFFSETS,
    _STEP,
    NoPathError,
    _reduced_cost_graph,
    astar_cells,
)
from robot_daemon.planning.local_planner import (
    ObstacleField,
    _rollout_with_trig,
    rollout,
)
from tests.robot_daemon.planning.numpy_reference import NumpyClearingCostmap, clearing_samples


def clearing_reference(
    x: float, y: float, angles: np.ndarray, reach: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """The dense (beams x samples) grid masked by ``t_k < reach``."""
    t = np.arange(0.0, float(reach.max()), step)
    inside = t[None, :] < reach[:, None]
    xs = x + np.cos(angles)[:, None] * t[None, :]
    ys = y + np.sin(angles)[:, None] * t[None, :]
    return xs[inside], ys[inside]


def costs_reference(costmap: Costmap, now: float) -> np.ndarray:
    """`Costmap.costs` from the whole grid's live cells."""
    live = costmap._marked_until > now
    if not live.any():
        return costmap.static_costs
    rows = np.flatnonzero(live.any(axis=1))
    cols = np.flatnonzero(live.any(axis=0))
    pad = math.ceil(costmap.config.inflation_radius / costmap.resolution) + 1
    h, w = live.shape
    r0, r1 = max(int(rows[0]) - pad, 0), min(int(rows[-1]) + pad + 1, h)
    c0, c1 = max(int(cols[0]) - pad, 0), min(int(cols[-1]) + pad + 1, w)
    live_distance = ndimage.distance_transform_edt(~live[r0:r1, c0:c1], sampling=costmap.resolution)
    distance = np.minimum(costmap.static_distance[r0:r1, c0:c1], live_distance)
    result = costmap.static_costs.copy()
    window = (slice(r0, r1), slice(c0, c1))
    result[window] = costmap._costs_from_distance(distance.astype(np.float32), window)
    return result


def octile_distance(rows: np.ndarray, cols: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """Octile distance [cells] from (rows, cols) to ``goal`` = (row, col): A*'s heuristic."""
    dr = np.abs(rows - goal[0]).astype(np.float64)
    dc = np.abs(cols - goal[1]).astype(np.float64)
    return np.maximum(dr, dc) + (math.sqrt(2.0) - 1.0) * np.minimum(dr, dc)


def graph_reference(costs: np.ndarray, goal: tuple[int, int], cost_weight: float) -> tuple:
    """A*'s reduced-cost CSR arrays with the octile formula on every (node, neighbour) pair."""
    h, w = costs.shape
    wp = w + 2
    padded = np.full((h + 2, wp), 254, dtype=np.uint8)
    padded[1:-1, 1:-1] = costs
    flat_cost = padded.ravel()
    free_flat = flat_cost < 253
    nodes = np.flatnonzero(free_flat)
    compact = np.full(flat_cost.size, -1, dtype=np.int64)
    compact[nodes] = np.arange(nodes.size)
    node_rows, node_cols = np.divmod(nodes, wp)
    goal_p = (goal[0] + 1, goal[1] + 1)
    heuristic = octile_distance(node_rows, node_cols, goal_p)
    neighbours = nodes[:, None] + (_OFFSETS[:, 0] * wp + _OFFSETS[:, 1])[None, :]
    traversable = free_flat[neighbours]
    neighbour_h = octile_distance(
        node_rows[:, None] + _OFFSETS[None, :, 0], node_cols[:, None] + _OFFSETS[None, :, 1], goal_p
    )
    cost_f = flat_cost.astype(np.float64)
    weight = _STEP[None, :] * (
        1.0 + (cost_f[nodes][:, None] + cost_f[neighbours]) * (0.5 / cost_weight)
    )
    reduced = (weight - heuristic[:, None] + neighbour_h)[traversable]
    np.maximum(reduced, 1e-12, out=reduced)
    indptr = np.concatenate(([0], np.cumsum(traversable.sum(axis=1))))
    return reduced, compact[neighbours[traversable]], indptr, nodes, compact, heuristic


def _room_grid() -> OccupancyGrid:
    cells = np.full((120, 160), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[40:80, 70:74] = OCCUPIED
    return OccupancyGrid(cells, 0.05, -1.0, -2.0)


def _scan(rng: np.random.Generator) -> LaserScan:
    ranges = rng.uniform(0.05, 8.0, 1081).astype(np.float32)
    ranges[rng.random(1081) < 0.05] = np.inf
    return LaserScan(0.0, -2.356194490192345, math.radians(0.25), 0.02, 30.0, ranges)


def test_clearing_samples_equal_the_masked_dense_grid() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        angles = rng.uniform(-math.pi, math.pi, 541)
        reach = rng.uniform(-0.5, 5.0, 541)
        reach[0] = 4.95  # at least one beam reaches
        x, y = rng.uniform(-3, 3, 2)
        fast = clearing_samples(float(x), float(y), angles, reach, 0.05)
        ref = clearing_reference(float(x), float(y), angles, reach, 0.05)
        assert np.array_equal(fast[0], ref[0]) and np.array_equal(fast[1], ref[1])


def test_costs_from_the_recent_mark_boxes_equal_the_whole_grid_scan() -> None:
    rng = np.random.default_rng(2)
    costmap = Costmap(_room_grid())
    now = 0.0
    for k in range(60):
        now += float(rng.uniform(0.05, 0.6))
        pose = Pose2D(
            float(rng.uniform(0.0, 6.0)), float(rng.uniform(-1.0, 3.5)), float(rng.uniform(-3, 3))
        )
        costmap.update(now, pose, _scan(rng))
        if k == 40:
            costmap.clear()
        # Queries now, later (marks expired), and back in time (the whole grid is consulted).
        for when in (now, now + 1.0, now + 2.5, now - 1.5):
            assert np.array_equal(costmap.costs(when), costs_reference(costmap, when))


def test_reduced_cost_graph_equals_the_octile_formula_everywhere() -> None:
    rng = np.random.default_rng(3)
    for _ in range(10):
        costs = rng.choice(np.array([0, 0, 0, 30, 120, 252, 253, 254], dtype=np.uint8), (40, 55))
        goal = (int(rng.integers(0, 40)), int(rng.integers(0, 55)))
        fast = _reduced_cost_graph(costs, goal, 100.0)
        ref = graph_reference(costs, goal, 100.0)
        for a, b in zip(fast[:6], ref, strict=True):
            assert np.array_equal(a, b)


def test_obstacle_field_lookup_equals_the_masked_lookup() -> None:
    rng = np.random.default_rng(4)
    field = ObstacleField(rng.uniform(-1.5, 1.5, (200, 2)), 1.4, 0.05)
    x, y = rng.uniform(-3.0, 3.0, (2, 5000))  # many points outside the grid
    col = np.floor((x + field.half_size) / field.resolution).astype(np.int64)
    row = np.floor((y + field.half_size) / field.resolution).astype(np.int64)
    inside = (row >= 0) & (row < field.n) & (col >= 0) & (col < field.n)
    ref = np.full(col.shape, np.inf)
    ref[inside] = field.distance[row[inside], col[inside]]
    assert np.array_equal(field.lookup(x, y), ref)


def test_rollout_with_the_callers_trig_equals_rollout() -> None:
    v = np.linspace(0.0, 0.25, 11).repeat(21)
    w = np.tile(np.linspace(-1.0, 1.0, 21), 11)
    w[5] = 1e-12  # a straight line: the small-angle limits
    times = 0.1 * np.arange(1, 16)
    theta = w[:, None] * times[None, :]
    fast = _rollout_with_trig(v, times, theta, np.sin(theta), np.cos(theta))
    for a, b in zip(fast, rollout(v, w, times), strict=True):
        assert np.array_equal(a, b)


def astar_reference(
    costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int], cost_weight: float
) -> tuple[list[tuple[int, int]], float]:
    """A* on the graph of the whole grid, built once (the search before `_search_box`)."""
    if start == goal:
        return [start], 0.0
    reduced, neighbour_compact, indptr, nodes, compact, heuristic, wp = _reduced_cost_graph(
        costs, goal, cost_weight
    )
    graph = csr_matrix((reduced, neighbour_compact, indptr), shape=(nodes.size, nodes.size))
    s = int(compact[(start[0] + 1) * wp + start[1] + 1])
    g = int(compact[(goal[0] + 1) * wp + goal[1] + 1])
    h_start = float(heuristic[s])
    limit = max(0.5 * h_start, 20.0)
    reached, previous_limit = -1, 0.0
    max_edge = float(reduced.max(initial=0.0))
    while True:
        dist, pred = dijkstra(graph, indices=s, return_predecessors=True, limit=limit)
        if math.isfinite(dist[g]) or limit == math.inf:
            break
        now_reached = int(np.count_nonzero(np.isfinite(dist)))
        if now_reached == reached and limit - previous_limit > max_edge:
            break
        reached, previous_limit = now_reached, limit
        limit = limit * 4.0 if limit < 4.0 * h_start + 100.0 else math.inf
    if not math.isfinite(dist[g]):
        raise NoPathError("no path")
    chain = [g]
    while chain[-1] != s:
        chain.append(int(pred[chain[-1]]))
    rows, cols = np.divmod(nodes[np.asarray(chain[::-1])], wp)
    return [(int(r) - 1, int(c) - 1) for r, c in zip(rows, cols, strict=True)], float(
        dist[g]
    ) + h_start


def _maze(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """Free floor (cost 0, ties everywhere), inflated bands, walls with gaps, a closed room."""
    costs = np.zeros(shape, dtype=np.uint8)
    h, w = shape
    for _ in range(int(rng.integers(2, 7))):
        if rng.random() < 0.5:
            r = int(rng.integers(0, h))
            costs[r, :] = 254
            gap = int(rng.integers(0, w - 3))
            costs[r, gap : gap + int(rng.integers(0, 4))] = 0
        else:
            c = int(rng.integers(0, w))
            costs[:, c] = 254
            gap = int(rng.integers(0, h - 3))
            costs[gap : gap + int(rng.integers(0, 4)), c] = 0
    soft = rng.random(shape) < 0.1
    costs[soft & (costs == 0)] = rng.choice(np.array([40, 128, 252], dtype=np.uint8))
    if rng.random() < 0.3:  # a closed room: no path into it
        costs[5:15, 5] = costs[5:15, 15] = costs[5, 5:16] = costs[15, 5:16] = 254
    return costs


def test_astar_on_the_search_box_equals_the_whole_grid_search() -> None:
    rng = np.random.default_rng(5)
    outcomes = {"path": 0, "none": 0, "detour": 0}
    for _ in range(150):
        shape = (int(rng.integers(20, 90)), int(rng.integers(20, 140)))
        costs = _maze(rng, shape)
        free = np.argwhere(costs < 253)
        start, goal = (tuple(int(v) for v in free[rng.integers(0, free.shape[0])]) for _ in "sg")
        try:
            ref = astar_reference(costs, start, goal, 100.0)
        except NoPathError:
            outcomes["none"] += 1
            with pytest.raises(NoPathError):
                astar_cells(costs, start, goal, 100.0)
            continue
        assert astar_cells(costs, start, goal, 100.0) == ref  # cells (ties included), cost
        outcomes["path"] += 1
        dr, dc = abs(start[0] - goal[0]), abs(start[1] - goal[1])
        octile = max(dr, dc) + (math.sqrt(2.0) - 1.0) * min(dr, dc)
        outcomes["detour"] += ref[1] - octile > max(0.5 * octile, 20.0)  # a second round
    assert min(outcomes.values()) > 3, outcomes


class _ForwardClearing(NumpyClearingCostmap):
    """`Costmap` clearing with every sample of every clearing beam (`clearing_samples`)."""

    def _clear_beams(
        self, now: float, x: float, y: float, angles: np.ndarray, reach: np.ndarray
    ) -> None:
        self._clear_cells(*clearing_samples(x, y, angles, reach, self.resolution))


def test_clearing_only_near_live_marks_leaves_the_same_live_obstacles() -> None:
    rng = np.random.default_rng(6)
    fast, ref = Costmap(_room_grid()), _ForwardClearing(_room_grid())
    now = 0.0
    pose = Pose2D(3.0, 1.0, 0.0)
    for k in range(80):
        now += float(rng.uniform(0.05, 0.3))
        if k % 10 == 0:  # a jump; otherwise a short drive
            pose = Pose2D(*rng.uniform((0.0, -1.0, -3.0), (6.0, 3.5, 3.0)))
        else:
            pose = Pose2D(pose.x + 0.05, pose.y + 0.02, pose.yaw + 0.03)
        scan = _scan(rng)
        if k % 4 == 0:  # a person close to the laser: wide angular windows
            ranges = scan.ranges.copy()
            ranges[500:560] = rng.uniform(0.05, 0.3, 60)
            scan = dataclasses.replace(scan, ranges=ranges)
        for costmap in (fast, ref):
            costmap.update(now, pose, scan, Pose2D(0.2, 0.0, 0.0))
        for when in (now, now + 0.5, now + 1.9):
            assert np.array_equal(fast.live_obstacles(when), ref.live_obstacles(when))
        assert np.array_equal(fast.costs(now), ref.costs(now))


def test_obstacle_field_distance_equals_scipy_to_the_last_places() -> None:
    rng = np.random.default_rng(7)
    for _ in range(40):
        free = rng.random((56, 56)) > rng.uniform(0.002, 0.3)
        free[int(rng.integers(0, 56)), int(rng.integers(0, 56))] = False
        rows, cols = np.nonzero(~free)
        centres = np.column_stack((cols + 0.5, rows + 0.5)) * 0.05 - 1.4  # cell centres [m]
        field = ObstacleField(centres, 1.4, 0.05)
        ref = ndimage.distance_transform_edt(free, sampling=0.05)
        np.testing.assert_allclose(field.distance, ref, rtol=4e-16, atol=0)


def test_local_plans_follow_a_new_configuration_of_the_same_planner() -> None:
    """The footprint circles and rollout times are kept per configuration (speed): a planner
    given a longer robot and a longer horizon plans as a new planner with them does."""
    from robot_daemon.planning.config import PlannerConfig
    from robot_daemon.planning.local_planner import DWAPlanner

    rng = np.random.default_rng(11)
    points = rng.uniform(-1.5, 1.5, (60, 2))
    points = points[np.hypot(points[:, 0], points[:, 1]) > 0.6]
    path = np.column_stack((np.linspace(0.0, 3.0, 30), 0.3 * np.sin(np.linspace(0.0, 3.0, 30))))
    planner = DWAPlanner(PlannerConfig())
    field = planner.make_field(points)
    first = planner.compute(Pose2D(0.0, 0.0, 0.0), (0.2, 0.0), path, field, 0.1)
    longer = PlannerConfig().replace(robot_length=0.9, sim_time=2.0)
    planner.config = longer
    changed = planner.compute(Pose2D(0.0, 0.0, 0.0), (0.2, 0.0), path, field, 0.1)
    fresh = DWAPlanner(longer).compute(Pose2D(0.0, 0.0, 0.0), (0.2, 0.0), path, field, 0.1)
    assert changed == fresh
    assert planner.footprint_clearance(field, 0.1, 0.0, 0.2) == DWAPlanner(
        longer
    ).footprint_clearance(field, 0.1, 0.0, 0.2)
    assert changed != first or changed.clearance != first.clearance


def test_two_axis_minimum_of_the_rollouts_equals_numpys() -> None:
    """`DWAPlanner.compute` takes the minimum over circles, then steps (speed)."""
    d = np.random.default_rng(12).uniform(0.0, 2.0, (3, 231, 15))
    d[1, 5, 7] = np.inf
    assert np.array_equal(d.min(axis=0).min(axis=1), d.min(axis=(0, 2)))
