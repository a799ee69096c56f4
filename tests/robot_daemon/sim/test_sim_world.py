"""World: walls + obstacles, distance transform bounds, footprint collisions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from robot_daemon.sim.diff_drive import RobotFootprint
from robot_daemon.sim.world import RectObstacle, World, WorldConfigError

RES = 0.05


def room() -> OccupancyGrid:
    """A 6 x 4 m room (0.05 m cells): one-cell walls on the border, an unknown patch."""
    cells = np.full((80, 120), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[60:70, 100:110] = UNKNOWN  # x 5.0-5.5, y 3.0-3.5
    return OccupancyGrid(cells, RES, 0.0, 0.0)


def test_unknown_and_off_map_are_walls() -> None:
    world = World(room())
    assert bool(world.is_blocked(5.2, 3.2))
    assert bool(world.is_blocked(-1.0, 1.0))
    assert bool(world.is_blocked(0.02, 1.0))
    assert not bool(world.is_blocked(1.0, 1.0))


def test_added_obstacle_is_rasterised() -> None:
    world = World(room())
    assert not bool(world.is_blocked(3.0, 2.0))
    version = world.version
    world.add_obstacle(RectObstacle(3.0, 2.0, 1.0, 1.0))
    assert world.version == version + 1
    assert bool(world.is_blocked(3.0, 2.0)) and bool(world.is_blocked(2.53, 1.53))
    assert not bool(world.is_blocked(2.4, 2.0)) and not bool(world.is_blocked(3.0, 2.6))
    world.add_obstacle(RectObstacle(1.0, 1.0, 0.01, 0.01))  # smaller than a cell: still one cell
    assert bool(world.is_blocked(1.0, 1.0))
    with pytest.raises(WorldConfigError, match="size_x"):
        RectObstacle(0, 0, 0.0, 1.0)


def brute_clearance(world: World, x: float, y: float) -> float:
    """Exact distance from (x, y) to the union of blocked cell squares (reference)."""
    blocked = world.blocked_padded[2:-2, 2:-2]
    rows, cols = np.nonzero(blocked)
    x0, y0 = cols * RES, rows * RES
    dx = np.maximum(np.maximum(x0 - x, x - (x0 + RES)), 0.0)
    dy = np.maximum(np.maximum(y0 - y, y - (y0 + RES)), 0.0)
    return float(np.hypot(dx, dy).min())


WORLD = World(room())


@settings(max_examples=200, deadline=None)
@given(x=st.floats(0.0, 6.0), y=st.floats(0.0, 4.0))
def test_clearance_is_a_tight_lower_bound(x: float, y: float) -> None:
    exact = brute_clearance(WORLD, x, y)
    bound = float(WORLD.clearance(x, y))
    assert bound <= exact + 1e-9
    assert bound >= exact - RES * math.sqrt(2) - 1e-9
    assert WORLD.clearance_at(x, y) == pytest.approx(bound)


def test_footprint_collision_with_walls_and_people() -> None:
    world = World(room())
    fp = RobotFootprint()
    assert not world.footprint_collides(fp, Pose2D(3.0, 2.0, 0.3))
    assert world.footprint_collides(fp, Pose2D(0.3, 2.0, 0.0))  # rear edge at 0.0 m
    assert not world.footprint_collides(fp, Pose2D(0.36, 2.0, 0.0))
    person = np.array([[3.6, 2.0, 0.25]])
    assert not world.footprint_collides(fp, Pose2D(3.0, 2.0, 0.0), person)  # gap 0.05 m
    assert world.footprint_collides(fp, Pose2D(3.1, 2.0, 0.0), person)
    assert world.footprint_clearance(fp, Pose2D(3.0, 2.0, 0.0), person) == pytest.approx(0.05)
    assert world.footprint_clearance(fp, Pose2D(0.3, 2.0, 0.0)) == 0.0
    wall_gap = world.footprint_clearance(fp, Pose2D(1.0, 2.0, 0.0))
    assert 0.7 - 0.05 - RES * math.sqrt(2) <= wall_gap <= 0.7 - 0.05 + 1e-9


def test_rotated_map_origin_is_rejected() -> None:
    grid = OccupancyGrid(np.zeros((4, 4), dtype=np.int8), 0.1, 0.0, 0.0, origin_yaw=0.5)
    with pytest.raises(WorldConfigError, match="yaw"):
        World(grid)
