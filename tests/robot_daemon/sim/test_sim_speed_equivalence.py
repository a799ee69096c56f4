"""The simulator's fast paths equal their plain versions, bit for bit (issue 12 speed work).

The float32 ray-casting field against the float64 one it replaced, the cast cache against a
fresh cast, and the metrics' footprint outline against ``RobotFootprint.outline``: equality, not
closeness, so the simulated scans (and the tours built on them) are unchanged. (The compiled
casters against the numpy ones: ``test_sim_sphere_tracing.py``, ``test_sim_analytic_rays.py``.)
"""

from __future__ import annotations

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.sim.diff_drive import RobotFootprint, to_world
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim, RayCaster
from robot_daemon.sim.world import PAD, RAY_FINE_STEP, SQRT2, RectObstacle, World
from tests.robot_daemon.sim.numpy_caster import numpy_refine


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


def walls_reference(
    world: World, x: float, y: float, angles: np.ndarray, max_t: float
) -> np.ndarray:
    """Sphere tracing as it was written before the speed work: float64 steps, separate u and v
    arrays, every beam in phase 1 until few are left, then chunks of fine samples [cells]."""
    field = world.ray_step_flat.astype(np.float64)
    width = world.padded_width
    u0, v0 = (float(c) for c in world.to_padded_cells(x, y))
    n = angles.size
    idx, t = np.arange(n), np.zeros(n)
    cs, sn = np.cos(angles), np.sin(angles)
    u, v = np.full(n, u0), np.full(n, v0)
    hits: dict[int, float] = {}
    iteration = 0
    while idx.size > max(64, n // 8):
        s = field[v.astype(np.intp) * width + u.astype(np.intp)]
        t += s
        u += s * cs
        v += s * sn
        iteration += 1
        if iteration % 3 == 0:
            done = (s == 0.0) | (t > max_t)
            hit = (s == 0.0) & (t <= max_t)
            hits.update(zip(idx[hit].tolist(), t[hit], strict=True))
            keep = ~done
            idx, t, u, v, cs, sn = idx[keep], t[keep], u[keep], v[keep], cs[keep], sn[keep]
    offsets = np.arange(96) * 0.5
    while idx.size:
        ts = t[:, None] + offsets[None, :]
        flat = (v0 + ts * sn[:, None]).astype(np.intp) * width + (u0 + ts * cs[:, None]).astype(
            np.intp
        )
        s = field[np.clip(flat, 0, field.size - 1)]
        first = (s == 0.0).argmax(axis=1)
        rows = np.arange(idx.size)
        blocked = s[rows, first] == 0.0
        t_hit = ts[rows, first]
        ok = blocked & (t_hit <= max_t)
        hits.update(zip(idx[ok].tolist(), t_hit[ok], strict=True))
        keep = ~blocked & (ts[:, -1] <= max_t)
        idx, t, cs, sn = idx[keep], (ts[:, -1] + s[:, -1])[keep], cs[keep], sn[keep]
    result = np.full(n, np.inf)
    result[list(hits)] = list(hits.values())
    return result


def test_walls_equal_the_sphere_tracing_before_the_speed_work() -> None:
    rng = np.random.default_rng(11)
    beams = LaserConfig().beam_angles()
    caster = RayCaster(WORLD)
    for x, y, yaw in _poses(rng, 40):
        angles = beams + yaw
        fast = caster.cast_walls(x, y, angles, 30.0)
        t_hit = walls_reference(WORLD, x, y, angles, 30.0 / WORLD.resolution)
        hit = np.isfinite(t_hit)
        assert np.array_equal(np.isfinite(fast), hit)
        cos, sin = np.cos(angles[hit]), np.sin(angles[hit])
        u0, v0 = (float(c) for c in WORLD.to_padded_cells(x, y))
        refined = numpy_refine(WORLD, u0, v0, cos, sin, t_hit[hit]) * WORLD.resolution
        assert np.array_equal(fast[hit], np.where(refined > 30.0, np.inf, refined))


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
        pts = to_world(pose, footprint.outline_local(WORLD.resolution / 2))
        ref = (
            0.0
            if WORLD.footprint_hits_wall(footprint, pose)
            else float(WORLD.clearance(pts[:, 0], pts[:, 1]).min())
        )
        assert WORLD.footprint_clearance(footprint, pose) == ref
