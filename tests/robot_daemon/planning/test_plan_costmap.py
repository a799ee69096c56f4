"""Costmap: Nav2 inflation values, unknown = lethal, live obstacles marked, cleared and expired."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from robot_daemon.planning.config import PlannerConfig, PlannerConfigError
from robot_daemon.planning.costmap import (
    INSCRIBED,
    LETHAL,
    Costmap,
    inflation_cost,
)

RES = 0.05


def empty_grid(width_m: float = 6.0, height_m: float = 4.0) -> OccupancyGrid:
    cells = np.full((round(height_m / RES), round(width_m / RES)), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = OCCUPIED
    cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyGrid(cells, RES, 0.0, 0.0)


def scan_towards(ranges: list[float], angle_min: float = -0.1, increment: float = 0.1) -> LaserScan:
    return LaserScan(0.0, angle_min, increment, 0.05, 30.0, np.array(ranges, dtype=np.float32))


def cost_at(cm: Costmap, now: float, x: float, y: float) -> int:
    """The cost of the cell holding map-frame point (x, y), read from `Costmap.costs`."""
    row, col = cm.grid.world_to_cell(x, y)
    return int(cm.costs(now)[int(row), int(col)])


def test_inflation_matches_nav2_formula_pointwise() -> None:
    d = np.array([0.0, 0.1, 0.275, 0.3, 0.4, 0.5, 0.6, 0.61, 2.0])
    cost = inflation_cost(d, 0.275, 0.6, 5.0)
    expected = [254, 253, 253]
    expected += [int(252 * math.exp(-5.0 * (x - 0.275))) for x in (0.3, 0.4, 0.5, 0.6)]
    expected += [0, 0]
    assert cost.tolist() == expected
    assert cost[3] == 222  # 252 * exp(-0.125) = 222.39, truncated like the C++ cast
    assert cost.dtype == np.uint8


@settings(max_examples=100, deadline=None)
@given(
    d=st.floats(0.0, 2.0),
    k=st.floats(1.0, 10.0),
    radius=st.floats(0.3, 1.0),
)
def test_inflation_is_monotone_and_bounded(d: float, k: float, radius: float) -> None:
    near, far = inflation_cost(np.array([d, d + 0.01]), 0.275, radius, k)
    assert far <= near <= LETHAL
    if 0.275 < d <= radius:
        assert near == math.floor(252 * math.exp(-k * (d - 0.275)))


def test_costmap_cells_follow_distance_to_wall() -> None:
    grid = empty_grid()
    cm = Costmap(grid)
    costs = cm.costs(0.0)
    row = costs.shape[0] // 2
    # Column 0 is the wall; column j's centre is j * RES from the wall's centre.
    for j in range(0, 16):
        assert costs[row, j] == inflation_cost(np.array([j * RES]), 0.275, 0.6, 5.0)[0]
    assert costs[row, 0] == LETHAL
    assert costs[row, 5] == INSCRIBED  # 0.25 m
    assert 0 < costs[row, 6] < INSCRIBED  # 0.30 m
    assert costs[row, 13] == 0  # 0.65 m > inflation radius


def test_unknown_cells_are_lethal() -> None:
    cells = np.full((40, 40), FREE, dtype=np.int8)
    cells[20, 20] = UNKNOWN
    cm = Costmap(OccupancyGrid(cells, RES, 0.0, 0.0))
    costs = cm.costs(0.0)
    assert costs[20, 20] == LETHAL
    assert costs[20, 24] == INSCRIBED
    assert costs[0, 0] == 0


def test_laser_marks_then_expires_and_ray_clears() -> None:
    grid = empty_grid()
    cm = Costmap(grid, PlannerConfig(obstacle_persistence=2.0))
    pose = Pose2D(1.0, 2.0, 0.0)
    cm.update(0.0, pose, scan_towards([1.5, 1.5, 1.5]))  # hits at about x = 2.5
    assert cost_at(cm, 0.1, 2.5, 2.0) == LETHAL
    assert cost_at(cm, 0.1, 2.5 - 0.2, 2.0) == INSCRIBED
    assert cost_at(cm, 0.1, 1.8, 2.0) < INSCRIBED  # the beam passed here
    # Expiry.
    assert cost_at(cm, 2.5, 2.5, 2.0) == 0
    # Ray clearing: the obstacle moved away; a longer beam through the cell clears it.
    cm.update(3.0, pose, scan_towards([1.5, 1.5, 1.5]))
    assert cost_at(cm, 3.1, 2.5, 2.0) == LETHAL
    cm.update(3.2, pose, scan_towards([3.0, 3.0, 3.0]))
    assert cost_at(cm, 3.3, 2.5, 2.0) < INSCRIBED
    assert cost_at(cm, 3.3, 4.0, 2.0) == LETHAL


def test_static_walls_are_never_cleared_and_clear_forgets_live_marks() -> None:
    grid = empty_grid()
    cm = Costmap(grid)
    pose = Pose2D(1.0, 2.0, 0.0)
    # A beam reaching beyond the right wall (a glitch) does not clear the wall.
    cm.update(0.0, pose, scan_towards([10.0, 10.0, 10.0]))
    assert cost_at(cm, 0.0, 5.97, 2.0) == LETHAL
    cm.update(0.0, pose, scan_towards([1.0, 1.0, 1.0]))
    assert cost_at(cm, 0.0, 2.0, 2.0) == LETHAL
    cm.clear()
    assert cost_at(cm, 0.0, 2.0, 2.0) == 0
    assert cost_at(cm, 0.0, 5.97, 2.0) == LETHAL


def test_beyond_obstacle_range_does_not_mark() -> None:
    cm = Costmap(empty_grid(12.0, 4.0), PlannerConfig(obstacle_max_range=4.0))
    cm.update(0.0, Pose2D(0.5, 2.0, 0.0), scan_towards([5.0, 5.0, 5.0]))
    assert cost_at(cm, 0.0, 5.5, 2.0) == 0


def test_live_inflation_equals_full_recomputation() -> None:
    grid = empty_grid()
    cm = Costmap(grid)
    rng = np.random.default_rng(3)
    ranges = rng.uniform(0.3, 2.0, 15)
    cm.update(0.0, Pose2D(3.0, 2.0, 0.0), scan_towards(list(ranges), -math.pi, 2 * math.pi / 15))
    marked = cm.live_obstacles(0.1)
    assert marked.sum() >= 10  # the beams' end points
    fast = cm.costs(0.1)
    cells = grid.cells.copy()
    cells[marked] = OCCUPIED
    reference = Costmap(grid.with_cells(cells)).costs(0.0)
    np.testing.assert_array_equal(fast, reference)


def test_door_of_0_9_m_stays_passable() -> None:
    cells = np.full((80, 80), FREE, dtype=np.int8)
    cells[:, 40] = OCCUPIED
    cells[31:49, 40] = FREE  # 18 cells = 0.9 m
    costs = Costmap(OccupancyGrid(cells, RES, 0.0, 0.0)).costs(0.0)
    assert costs[:, 40].min() < INSCRIBED
    assert int((costs[:, 40] < INSCRIBED).sum()) >= 6  # >= 0.3 m of free centres


@pytest.mark.parametrize(
    "changes",
    [
        {"robot_width": 0.0},
        {"inflation_radius": 0.1},
        {"cost_scaling_factor": math.nan},
        {"obstacle_persistence": 0.0},
    ],
)
def test_invalid_costmap_config_names_the_field(changes: dict[str, float]) -> None:
    """The costmap is configured by the planner's configuration, which names the field."""
    with pytest.raises(PlannerConfigError, match=next(iter(changes))):
        PlannerConfig(**changes)


def test_allow_unknown_makes_unknown_traversable_at_the_highest_cost() -> None:
    """Nav2's allow_unknown: unknown cells are not obstacles (not inflated) but cost 252."""
    from robot_daemon.planning.costmap import UNKNOWN_COST

    cells = np.full((40, 40), FREE, dtype=np.int8)
    cells[:, 20:] = UNKNOWN
    grid = OccupancyGrid(cells, 0.05, 0.0, 0.0)
    strict = Costmap(grid).costs(0.0)
    assert strict[10, 25] == LETHAL and strict[10, 17] >= 253  # lethal and inflated
    nav2 = Costmap(grid, PlannerConfig(allow_unknown=True))
    costs = nav2.costs(0.0)
    assert costs[10, 25] == UNKNOWN_COST and costs[10, 17] == 0  # dear, not inflated
    nav2.reconfigure(PlannerConfig(allow_unknown=False))
    assert nav2.costs(0.0)[10, 25] == LETHAL
