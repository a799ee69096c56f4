"""The simulator's fast paths equal their plain versions, bit for bit (issue 12 speed work).

Windows of beams (people, glass panes) against every beam, the float32 ray-casting field against
the float64 one it replaced, the cast cache against a fresh cast, and the metrics' footprint
outline against ``RobotFootprint.outline``: equality, not closeness, so the simulated scans (and
the tours built on them) are unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.sim.diff_drive import RobotFootprint
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim, RayCaster
from robot_daemon.sim.world import PAD, RAY_FINE_STEP, SQRT2, RectObstacle, World


def _office() -> World:
    cells = np.full((150, 250), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[60:64, 40:200] = OCCUPIED  # a long wall: grazing beams
    cells[90:150, 120:123] = OCCUPIED
    return World(
        OccupancyGrid(cells, 0.02, -1.0, -1.0),
        obstacles=[RectObstacle(1.5, 0.2, 0.4, 0.3, 0.4)],
        glass=[(2.0, 0.5, 2.04, 1.2), (0.2, 1.6, 0.9, 1.64)],
    )


WORLD = _office()


def _poses(rng: np.random.Generator, n: int) -> list[tuple[float, float, float]]:
    free = np.argwhere(WORLD.edt_cells > 3)
    picks = free[rng.integers(0, free.shape[0], n)]
    res = WORLD.resolution
    return [
        (
            WORLD.grid.origin_x + (c - PAD + 0.5) * res,
            WORLD.grid.origin_y + (r - PAD + 0.5) * res,
            float(rng.uniform(-4.0, 4.0)),
        )
        for r, c in picks
    ]


def test_ray_field_is_float32_holding_the_float64_steps() -> None:
    world = World(WORLD.grid, WORLD.obstacles)  # no panes: the laser's field is edt_cells'
    step = np.maximum(world.edt_cells - SQRT2, RAY_FINE_STEP)
    step[world.blocked_padded] = 0.0
    assert world.ray_step_flat.dtype == np.float32
    assert np.array_equal(world.ray_step_flat.astype(np.float64), step.astype(np.float64).ravel())


def test_walls_with_the_float32_field_equal_the_float64_field() -> None:
    rng = np.random.default_rng(11)
    wide = World(WORLD.grid, WORLD.obstacles, WORLD.glass)
    wide.ray_step_flat = wide.ray_step_flat.astype(np.float64)
    beams = LaserConfig().beam_angles()
    for x, y, yaw in _poses(rng, 40):
        fast = RayCaster(WORLD).cast_walls(x, y, beams + yaw, 30.0)
        ref = RayCaster(wide).cast_walls(x, y, beams + yaw, 30.0)
        assert np.array_equal(fast, ref)


def test_people_windows_equal_every_beam() -> None:
    rng = np.random.default_rng(12)
    beams = LaserConfig().beam_angles()
    for k, (x, y, yaw) in enumerate(_poses(rng, 60)):
        n = int(rng.integers(1, 7))
        circles = np.column_stack(
            (x + rng.uniform(-3, 3, n), y + rng.uniform(-3, 3, n), rng.uniform(0.05, 0.4, n))
        )
        if k % 5 == 0:
            circles[0, :2] = (x + 0.05, y)  # the laser inside a person
        if k % 7 == 0:
            circles[-1] = circles[0]  # a tie: the first circle wins
        angles = beams + yaw + (2 * math.pi if k % 3 == 0 else 0.0)  # windows past +-pi
        fast = RayCaster.cast_circles(x, y, angles, circles, increasing=True)
        ref = RayCaster.cast_circles(x, y, angles, circles, increasing=False)
        assert np.array_equal(fast[0], ref[0]) and np.array_equal(fast[1], ref[1])


def test_glass_windows_equal_every_beam() -> None:
    rng = np.random.default_rng(13)
    beams = LaserConfig().beam_angles()
    caster = RayCaster(WORLD)
    poses = [*_poses(rng, 80), (2.02, 0.8, 0.3)]  # the last one inside a pane
    for x, y, yaw in poses:
        angles = beams + yaw
        fast = caster.cast_glass(x, y, angles, 0.5, increasing=True)
        ref = caster.cast_glass(x, y, angles, 0.5, increasing=False)
        assert np.array_equal(fast, ref)


def test_cast_cache_equals_a_fresh_cast_and_sees_new_furniture() -> None:
    world = _office()
    caster = RayCaster(world)
    beams = LaserConfig().beam_angles()
    first = caster.cast(0.5, 0.5, beams, 30.0)
    again = caster.cast(0.5, 0.5, beams, 30.0)
    assert np.array_equal(first, again)
    assert np.array_equal(again, RayCaster(world).cast(0.5, 0.5, beams, 30.0))
    world.add_obstacle(RectObstacle(1.2, 0.5, 0.2, 0.2))
    after = caster.cast(0.5, 0.5, beams, 30.0)
    assert np.array_equal(after, RayCaster(world).cast(0.5, 0.5, beams, 30.0))
    assert not np.array_equal(after, first)


def test_scans_from_one_pose_twice_equal_two_fresh_simulators() -> None:
    config = LaserConfig.realistic()
    cached = LaserSim(WORLD, config, np.random.default_rng(5))
    pose = Pose2D(0.6, 0.4, 0.2)
    scans = [cached.scan(pose, 0.1 * k) for k in range(3)]
    fresh = LaserSim(WORLD, config, np.random.default_rng(5))
    fresh_scans = []
    for k in range(3):
        fresh.caster = RayCaster(WORLD)  # no cache to hit
        fresh_scans.append(fresh.scan(pose, 0.1 * k))
    for a, b in zip(scans, fresh_scans, strict=True):
        assert np.array_equal(a.ranges, b.ranges)


def test_footprint_clearance_uses_the_outline_of_the_footprint() -> None:
    rng = np.random.default_rng(14)
    footprint = RobotFootprint()
    for x, y, yaw in _poses(rng, 30):
        pose = Pose2D(x, y, yaw)
        pts = footprint.outline(pose, WORLD.resolution / 2)
        ref = (
            0.0
            if WORLD.footprint_hits_wall(footprint, pose)
            else float(WORLD.clearance(pts[:, 0], pts[:, 1]).min())
        )
        assert WORLD.footprint_clearance(footprint, pose) == ref
