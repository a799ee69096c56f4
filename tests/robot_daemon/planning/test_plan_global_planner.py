"""Global planner: A* optimality against a reference Dijkstra, clearance, doors, errors."""

from __future__ import annotations

import heapq
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid, load_map
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import INSCRIBED, Costmap
from robot_daemon.planning.global_planner import (
    GlobalPlanner,
    GoalBlockedError,
    NoPathError,
    StartBlockedError,
    astar_cells,
)

RES = 0.05


def path_cost(costs: np.ndarray, cells: list[tuple[int, int]], cost_weight: float) -> float:
    """Cost [cells] of a cell path under `astar_cells`' step cost."""
    total = 0.0
    for (r0, c0), (r1, c1) in itertools.pairwise(cells):
        step = math.hypot(r1 - r0, c1 - c0)
        total += step * (1.0 + (float(costs[r0, c0]) + float(costs[r1, c1])) / (2.0 * cost_weight))
    return total


def reference_dijkstra(
    costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int], weight: float
) -> float:
    """Textbook Dijkstra with the same step cost; inf when unreachable."""
    h, w = costs.shape
    best = {start: 0.0}
    queue = [(0.0, start)]
    while queue:
        d, (r, c) = heapq.heappop(queue)
        if (r, c) == goal:
            return d
        if d > best[(r, c)]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                nr, nc = r + dr, c + dc
                if (dr, dc) == (0, 0) or not (0 <= nr < h and 0 <= nc < w):
                    continue
                if costs[nr, nc] >= INSCRIBED:
                    continue
                step = math.hypot(dr, dc) * (
                    1.0 + (float(costs[r, c]) + float(costs[nr, nc])) / (2.0 * weight)
                )
                if d + step < best.get((nr, nc), math.inf):
                    best[(nr, nc)] = d + step
                    heapq.heappush(queue, (d + step, (nr, nc)))
    return math.inf


@st.composite
def cost_grids(draw: st.DrawFn) -> tuple[np.ndarray, tuple[int, int], tuple[int, int], float]:
    h = draw(st.integers(2, 12))
    w = draw(st.integers(2, 12))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    levels = np.array([0, 0, 0, 10, 80, 200, 252, 253, 254], dtype=np.uint8)
    costs = rng.choice(levels, size=(h, w))
    free = np.argwhere(costs < INSCRIBED)
    if len(free) < 1:
        costs[0, 0] = 0
        free = np.argwhere(costs < INSCRIBED)
    i = draw(st.integers(0, len(free) - 1))
    j = draw(st.integers(0, len(free) - 1))
    weight = draw(st.sampled_from([1.0, 50.0, 100.0, 1000.0]))
    return costs, tuple(free[i]), tuple(free[j]), weight


@settings(max_examples=200, deadline=None)
@given(cost_grids())
def test_astar_is_optimal_against_reference_dijkstra(
    case: tuple[np.ndarray, tuple[int, int], tuple[int, int], float],
) -> None:
    costs, start, goal, weight = case
    expected = reference_dijkstra(costs, start, goal, weight)
    if math.isinf(expected):
        with pytest.raises(NoPathError):
            astar_cells(costs, start, goal, weight)
        return
    cells, cost = astar_cells(costs, start, goal, weight)
    assert cost == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert cells[0] == start and cells[-1] == goal
    assert path_cost(costs, cells, weight) == pytest.approx(expected, rel=1e-9, abs=1e-9)
    for (r0, c0), (r1, c1) in itertools.pairwise(cells):
        assert max(abs(r1 - r0), abs(c1 - c0)) == 1
    assert all(costs[r, c] < INSCRIBED for r, c in cells)


def office(door_m: float = 0.9) -> OccupancyGrid:
    """10 x 6 m: outer walls, a wall at x = 5 m with one door centred at y = 3 m, a pillar."""
    cells = np.full((120, 200), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = OCCUPIED
    cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[:, 100:102] = OCCUPIED
    half = round(door_m / RES) // 2
    cells[60 - half : 60 - half + round(door_m / RES), 100:102] = FREE
    cells[20:40, 40:50] = OCCUPIED  # pillar
    return OccupancyGrid(cells, RES, 0.0, 0.0, source="office")


def clearance(grid: OccupancyGrid, points: list[tuple[float, float]]) -> float:
    occ = np.argwhere(grid.blocked())
    ox, oy = grid.cell_to_world(occ[:, 0], occ[:, 1])
    p = np.asarray(points)
    d = np.hypot(p[:, None, 0] - ox[None, :], p[:, None, 1] - oy[None, :])
    return float(d.min())


def test_path_passes_a_0_9_m_door_with_clearance() -> None:
    grid = office(0.9)
    costs = Costmap(grid).costs(0.0)
    path = GlobalPlanner(grid).plan(costs, (1.0, 1.0), (9.0, 5.0))
    assert path[0] == pytest.approx((1.0, 1.0)) and path[-1] == pytest.approx((9.0, 5.0))
    p = np.asarray(path)
    crossing = p[np.argmin(np.abs(p[:, 0] - 5.05))]
    assert abs(crossing[1] - 3.0) < 0.2  # through the door
    assert clearance(grid, path) > 0.275  # the footprint's inscribed radius
    rows, cols = grid.world_to_cell(p[:, 0], p[:, 1])
    assert np.all(costs[rows, cols] < INSCRIBED)
    steps = np.hypot(*np.diff(p, axis=0).T)
    assert steps.max() <= 0.25 + 1e-9
    assert steps.sum() < 1.25 * math.hypot(8.0, 4.0)  # smoothed, not a staircase


def test_line_of_sight_path_is_straight() -> None:
    grid = office()
    path = GlobalPlanner(grid).plan(Costmap(grid).costs(0.0), (1.0, 4.0), (4.0, 5.0))
    p = np.asarray(path)
    # All points on the straight segment (shortcutting removed the grid staircase).
    t = (p[:, 0] - 1.0) / 3.0
    np.testing.assert_allclose(p[:, 1], 4.0 + t, atol=1e-6)


def test_too_narrow_door_has_no_path() -> None:
    grid = office(0.5)
    with pytest.raises(NoPathError, match="office"):
        GlobalPlanner(grid).plan(Costmap(grid).costs(0.0), (1.0, 1.0), (9.0, 5.0))


def test_start_and_goal_errors_and_start_snapping() -> None:
    grid = office()
    costs = Costmap(grid).costs(0.0)
    planner = GlobalPlanner(grid)
    with pytest.raises(StartBlockedError, match="start"):
        planner.plan(costs, (2.25, 1.5), (9.0, 5.0))  # inside the pillar
    with pytest.raises(GoalBlockedError, match="goal"):
        planner.plan(costs, (1.0, 1.0), (5.05, 1.0))  # inside the wall
    with pytest.raises(GoalBlockedError, match="outside"):
        planner.plan(costs, (1.0, 1.0), (50.0, 1.0))
    # 0.15 m from the left wall: inscribed space; the path starts at the nearest free point.
    path = planner.plan(costs, (0.25, 3.0), (3.0, 3.0))
    x0, y0 = path[0]
    assert 0.25 < x0 < 0.6 and abs(y0 - 3.0) < 0.15
    r, c = grid.world_to_cell(x0, y0)
    assert costs[int(r), int(c)] < INSCRIBED


def test_fine_grid_planning_agrees() -> None:
    grid = office()
    costs = Costmap(grid).costs(0.0)
    coarse = GlobalPlanner(grid).plan(costs, (1.0, 1.0), (9.0, 5.0))
    fine = GlobalPlanner(grid, PlannerConfig(planning_resolution=RES)).plan(
        costs, (1.0, 1.0), (9.0, 5.0)
    )
    length = lambda p: float(np.hypot(*np.diff(np.asarray(p), axis=0).T).sum())  # noqa: E731
    assert length(coarse) == pytest.approx(length(fine), rel=0.1)


@pytest.mark.realdata
def test_willow_corner_to_corner(shared_data: Path) -> None:
    grid = load_map(shared_data / "maps" / "willow.yaml")
    costs = Costmap(grid).costs(0.0)
    free = np.argwhere(costs == 0)
    i, j = np.argmin(free.sum(axis=1)), np.argmax(free.sum(axis=1))
    start = tuple(float(v) for v in grid.cell_to_world(*free[i]))
    goal = tuple(float(v) for v in grid.cell_to_world(*free[j]))
    path = GlobalPlanner(grid).plan(costs, start, goal)  # type: ignore[arg-type]
    p = np.asarray(path)
    rows, cols = grid.world_to_cell(p[:, 0], p[:, 1])
    assert np.all(costs[rows, cols] < INSCRIBED)
    assert len(path) * 0.25 > math.dist(start, goal)


def test_bounded_search_grows_until_a_long_detour_is_found() -> None:
    # A wall forces a detour far longer than the first f-bound (0.5 h + 20 cells).
    costs = np.zeros((80, 80), dtype=np.uint8)
    costs[2:80, 40] = 254
    start, goal = (78, 20), (78, 60)
    cells, cost = astar_cells(costs, start, goal, 100.0)
    assert cost == pytest.approx(reference_dijkstra(costs, start, goal, 100.0), rel=1e-9)
    assert cost > 0.5 * 40 + 20 + 40  # the growth loop ran
    assert min(r for r, _ in cells) <= 1


def test_unreachable_goal_in_a_large_grid_raises() -> None:
    costs = np.zeros((60, 60), dtype=np.uint8)
    costs[:, 30] = 254
    with pytest.raises(NoPathError):
        astar_cells(costs, (5, 5), (50, 50), 100.0)
