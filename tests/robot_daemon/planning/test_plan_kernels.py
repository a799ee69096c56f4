"""The planner's compiled kernels (`robot_daemon.jit`) equal the numpy code they replaced
(`numpy_reference`), bit for bit, on random inputs and on a simulated robot's own; compiled
and plain Python agree; and a run after `jit.warm_up` compiles nothing more."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon import jit
from robot_daemon.planning import costmap as costmap_module
from robot_daemon.planning import global_planner, local_planner, scan_filter
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import Costmap
from robot_daemon.planning.global_planner import GlobalPlanner, PlanningError, coarsen_costs
from robot_daemon.planning.local_planner import DWAPlanner, ObstacleField, obstacle_points_near
from robot_daemon.planning.navigator import Navigator
from robot_daemon.planning.scan_filter import shadow_mask
from tests.robot_daemon.planning.numpy_reference import (
    NumpyClearingCostmap,
    NumpyDWAPlanner,
    NumpyGlobalPlanner,
    NumpyNavigator,
    numpy_astar_cells,
    numpy_obstacle_points_near,
    numpy_reduced_cost_graph,
    numpy_shadow_mask,
    numpy_shortcut,
    obstacle_field_distance,
)
from tests.robot_daemon.planning.recorded_navigation import RecordedNavigation, record_tour


def _room_grid() -> OccupancyGrid:
    cells = np.full((120, 160), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[40:80, 70:74] = OCCUPIED
    return OccupancyGrid(cells, 0.05, -1.0, -2.0)


def _scan(rng: np.random.Generator, increment: float = math.radians(0.25)) -> LaserScan:
    ranges = rng.uniform(0.05, 8.0, 1081).astype(np.float32)
    ranges[rng.random(1081) < 0.05] = np.inf
    ranges[rng.random(1081) < 0.01] = np.nan
    angle_min = -2.356194490192345 if increment > 0 else 2.356194490192345
    return LaserScan(0.0, angle_min, increment, 0.02, 30.0, ranges)


def test_clearing_kernel_leaves_the_live_marks_numpy_clearing_left() -> None:
    rng = np.random.default_rng(21)
    grid = _room_grid()
    fast, ref = Costmap(grid), NumpyClearingCostmap(grid)
    now = 0.0
    pose = Pose2D(3.0, 1.0, 0.0)
    for k in range(120):
        now += float(rng.uniform(0.05, 0.3))
        if k % 10 == 0:  # a jump (off the grid too); otherwise a short drive
            pose = Pose2D(*rng.uniform((-2.0, -3.0, -3.0), (8.0, 5.0, 3.0)))
        else:
            pose = Pose2D(pose.x + 0.05, pose.y + 0.02, pose.yaw + 0.03)
        scan = _scan(rng, math.radians(0.25) if k % 7 else -math.radians(0.25))
        if k % 4 == 0:  # a person close to the laser
            ranges = scan.ranges.copy()
            ranges[500:560] = rng.uniform(0.05, 0.3, 60)
            scan = dataclasses.replace(scan, ranges=ranges)
        for costmap in (fast, ref):
            costmap.update(now, pose, scan, Pose2D(0.2, 0.0, 0.0))
        for when in (now, now + 0.5, now + 1.9):
            assert np.array_equal(fast.live_obstacles(when), ref.live_obstacles(when))
        assert np.array_equal(fast.costs(now), ref.costs(now))
        # Where they differ at all, it is in marks dead before `now` (forgotten or not).
        differ = fast._marked_until != ref._marked_until
        assert not np.any(differ & ((fast._marked_until > now) | (ref._marked_until > now)))


def test_clearing_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(22)
    for _ in range(20):
        marked = np.where(rng.random((60, 80)) < 0.3, rng.uniform(-1.0, 3.0, (60, 80)), -np.inf)
        angles = np.sort(rng.uniform(-math.pi, math.pi, 300))
        reach = rng.uniform(-0.5, 5.0, 300)
        t = np.arange(0.0, float(reach.max()), 0.05)
        x, y = (float(v) for v in rng.uniform(-1.0, 4.0, 2))
        args = (-0.5, -0.7, 0.05, x, y, np.cos(angles), np.sin(angles), t, reach, 1.0)
        compiled, plain = marked.copy(), marked.copy()
        costmap_module.clear_live_cells(compiled, *args)
        jit.python_function(costmap_module.clear_live_cells)(plain, *args)
        assert np.array_equal(compiled, plain)
        assert not np.array_equal(compiled, marked)  # something was cleared


def _random_local_problem(
    rng: np.random.Generator,
) -> tuple[Pose2D, tuple[float, float], np.ndarray, np.ndarray, float, float | None]:
    """A pose, a velocity, a path, obstacle points (robot frame), dt and goal distance."""
    pose = Pose2D(*rng.uniform((-2.0, -2.0, -math.pi), (2.0, 2.0, math.pi)))
    velocity = (float(rng.uniform(-0.05, 0.3)), float(rng.uniform(-1.0, 1.0)))
    if rng.random() < 0.2:
        velocity = (0.0, 0.0)
    heading = float(rng.uniform(-math.pi, math.pi))
    s = np.linspace(0.0, float(rng.uniform(0.0, 4.0)), int(rng.integers(1, 60)))
    bend = float(rng.uniform(-0.5, 0.5))
    path = np.column_stack(
        (
            pose.x + s * math.cos(heading) - bend * s**2 * math.sin(heading),
            pose.y + s * math.sin(heading) + bend * s**2 * math.cos(heading),
        )
    )
    count = int(rng.choice([0, 5, 40, 300]))
    points = rng.uniform(-1.6, 1.6, (count, 2))
    points = points[np.hypot(points[:, 0], points[:, 1]) > rng.uniform(0.3, 0.8)]
    if rng.random() < 0.2:  # a wall beside the robot, within the local planner's margin
        side = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.39, 0.43))
        wall = np.column_stack((np.linspace(-1.5, 1.5, 60), np.full(60, side)))
        points = np.vstack((points, wall))
    goal = None if rng.random() < 0.5 else float(rng.uniform(0.0, 2.0))
    return pose, velocity, path, points, float(rng.uniform(0.05, 0.2)), goal


def test_dwa_with_the_rollout_kernel_plans_what_the_numpy_rollouts_planned() -> None:
    rng = np.random.default_rng(23)
    modes: dict[str, int] = {}
    for _ in range(400):
        pose, velocity, path, points, dt, goal = _random_local_problem(rng)
        fast, ref = DWAPlanner(PlannerConfig()), NumpyDWAPlanner(PlannerConfig())
        field = fast.make_field(points)
        plan = fast.compute(pose, velocity, path, field, dt, goal)
        assert plan == ref.compute(pose, velocity, path, field, dt, goal)
        modes[plan.mode] = modes.get(plan.mode, 0) + 1
    assert set(modes) == {"dwa", "rotate_to_heading", "make_room", "escape", "brake"}, modes


def test_rollout_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(24)
    field = ObstacleField(rng.uniform(-1.5, 1.5, (80, 2)), 1.4, 0.05)
    v = rng.uniform(-0.1, 0.3, 11)
    w = rng.uniform(-1.0, 1.0, 21)
    w[:3] = (0.0, 1e-12, -1e-10)  # straight lines: the ratios' limits
    times = 0.1 * np.arange(1, 16, dtype=np.float64)
    theta = w[:, None] * times[None, :]
    args = (v, w, times, np.cos(theta), np.sin(theta), np.array([-0.2, 0.0, 0.2]))
    grid = (field.bordered, field.n, field.half_size, field.resolution)
    compiled = local_planner.rollout_clearance(*args, *grid)
    plain = jit.python_function(local_planner.rollout_clearance)(*args, *grid)
    for a, b in zip(compiled, plain, strict=True):
        assert np.array_equal(a, b)
    assert np.isfinite(compiled[2]).all() and np.isinf(compiled[2]).sum() == 0


@pytest.fixture(scope="module")
def recorded() -> RecordedNavigation:
    """1200 loop steps (60 s) of the realistic tour with 12 people: 500 navigation cycles."""
    return record_tour(1200, seed=1, people=12)[1]


def test_a_robots_navigation_replays_the_same_through_the_numpy_navigator(
    recorded: RecordedNavigation,
) -> None:
    fast = Navigator(recorded.grid, recorded.config)
    ref = NumpyNavigator(recorded.grid, recorded.config)
    assert recorded.replay(fast) == recorded.commands  # deterministic: the robot's own
    assert recorded.replay(ref) == recorded.commands
    assert fast.path == ref.path
    assert np.array_equal(fast._last_obstacle_points, ref._last_obstacle_points)
    now = recorded.calls[-1][1][0]
    assert np.array_equal(fast.costmap.live_obstacles(now), ref.costmap.live_obstacles(now))
    assert np.count_nonzero(fast.costmap.live_obstacles(now)) > 100  # clutter, people


def test_obstacle_field_equals_the_opencv_field_it_replaced() -> None:
    rng = np.random.default_rng(25)
    for trial in range(300):
        half, res = float(rng.choice([1.382, 1.4, 0.5, 2.0])), float(rng.choice([0.05, 0.1]))
        count = int(rng.choice([0, 1, 2, 10, 100, 1000, 5000]))
        points = rng.uniform(-half - 0.5, half + 0.5, (count, 2))
        if trial % 3 == 0:  # lines of points: walls, seen at an angle
            t = rng.uniform(0.0, 1.0, count)[:, None]
            a, b = rng.uniform(-half, half, (2, 1, 2))
            points = a + t * (b - a)
        field = ObstacleField(points, half, res)
        assert np.array_equal(field.distance, obstacle_field_distance(points, half, res))
        bordered = field.bordered.reshape(field.n + 2, field.n + 2)
        assert np.isinf(bordered[[0, -1], :]).all() and np.isinf(bordered[:, [0, -1]]).all()
        plain = jit.python_function(local_planner.obstacle_distance)
        if trial % 10 == 0:  # plain Python is slow: a sample
            assert np.array_equal(plain(points, half, res, field.n), field.bordered)


def test_marking_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(26)
    for _ in range(20):
        marked = np.where(rng.random((200, 200)) < 0.3, rng.uniform(-1, 3, (200, 200)), -np.inf)
        scan = _scan(rng)
        cos, sin = scan.trig()
        yaw = float(rng.uniform(-math.pi, math.pi))
        args = (
            scan.valid(),
            scan.ranges.astype(np.float64),
            cos,
            sin,
            4.0,
            *(float(v) for v in rng.uniform(-1.0, 4.0, 2)),
            math.cos(yaw),
            math.sin(yaw),
            -5.0,
            -5.5,
            0.05,
            2.0,
        )
        compiled, plain = marked.copy(), marked.copy()
        box = costmap_module.mark_endpoints(compiled, *args)
        assert box == jit.python_function(costmap_module.mark_endpoints)(plain, *args)
        assert np.array_equal(compiled, plain)
        assert box[0] >= 0 and np.count_nonzero(compiled == 2.0) > 10


WARM_RUN = """
import importlib, json, pkgutil
import robot_daemon.planning, robot_daemon.safety
from robot_daemon import jit
modules = [
    importlib.import_module(f"{package.__name__}.{info.name}")
    for package in (robot_daemon.planning, robot_daemon.safety)
    for info in pkgutil.iter_modules(package.__path__)
]
kernels = {
    f"{module.__name__}.{name}": value
    for module in modules
    for name, value in vars(module).items()
    if hasattr(value, "signatures") and hasattr(value, "py_func")
}
jit.warm_up()
before = {name: [str(s) for s in kernel.signatures] for name, kernel in kernels.items()}
from tests.robot_daemon.planning.recorded_navigation import record_tour
record_tour(400, seed=2, people=12)
after = {name: [str(s) for s in kernel.signatures] for name, kernel in kernels.items()}
print(json.dumps({"enabled": jit.ENABLED, "before": before, "after": after}))
"""


def test_a_run_after_the_warm_up_compiles_no_planning_or_safety_kernel_again() -> None:
    """400 loop steps of the realistic tour after `jit.warm_up`: no kernel of
    `robot_daemon.planning` or `robot_daemon.safety` gets a new signature (no compiling in the
    control loop); in a fresh process, so that no other test's calls count."""
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = subprocess.run(
        [sys.executable, "-c", WARM_RUN], cwd=root, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr[-3000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["before"] == result["after"]
    if result["enabled"]:  # one specialisation each (kernels called only by kernels: none)
        assert sum(len(signatures) == 1 for signatures in result["before"].values()) >= 6
        assert all(len(signatures) <= 1 for signatures in result["before"].values()), result


def test_reduced_cost_graph_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(27)
    levels = np.array([0, 0, 0, 30, 120, 252, 253, 254], dtype=np.uint8)
    for _ in range(10):
        costs = rng.choice(levels, (30, 45))
        padded = np.full((32, 47), 254, dtype=np.uint8)
        padded[1:-1, 1:-1] = costs
        flat = padded.ravel()
        nodes = np.flatnonzero(flat < 253)
        goal = (int(rng.integers(1, 31)), int(rng.integers(1, 46)))
        args = (flat, nodes, 47, *goal, global_planner._OFFSETS, global_planner._STEP, 100.0)
        compiled = global_planner.reduced_cost_edges(*args)
        plain = jit.python_function(global_planner.reduced_cost_edges)(*args)
        for a, b in zip(compiled, plain, strict=True):
            assert np.array_equal(a, b)


def test_reduced_cost_graph_equals_numpys_on_the_isr_floor(recorded: RecordedNavigation) -> None:
    rng = np.random.default_rng(28)
    costs = Costmap(recorded.grid).static_costs
    free = np.argwhere(costs < 253)
    for _ in range(30):
        row, col = free[rng.integers(0, free.shape[0])]
        r0, c0 = max(int(row) - 80, 0), max(int(col) - 120, 0)
        window = costs[r0 : r0 + 160, c0 : c0 + 240]
        goal = (int(rng.integers(0, window.shape[0])), int(rng.integers(0, window.shape[1])))
        weight = float(rng.choice([100.0, 50.0, 3.0]))
        fast = global_planner._reduced_cost_graph(window, goal, weight)
        ref = numpy_reduced_cost_graph(window, goal, weight)
        assert fast[6] == ref[6]
        for a, b in zip(fast[:6], ref[:6], strict=True):
            assert a.dtype == b.dtype and np.array_equal(a, b)


def test_the_segments_samples_are_numpys_linspace() -> None:
    """`segment_max_costs` samples at ``k * (1 / (m - 1))``, the last at 1: what
    ``numpy.linspace(0, 1, m)`` gives (checked here for every ``m`` a plan can need)."""
    for m in range(2, 6000):
        step = 1.0 / (m - 1)
        ours = np.array([1.0 if k == m - 1 else k * step for k in range(m)])
        assert np.array_equal(ours, np.linspace(0.0, 1.0, m)), m


def test_shortcut_kernel_keeps_the_vertices_numpys_shortcut_kept(
    recorded: RecordedNavigation,
) -> None:
    rng = np.random.default_rng(29)
    grid = recorded.grid
    costmap = Costmap(grid)
    planner = NumpyGlobalPlanner(grid, recorded.config)
    free = np.argwhere(costmap.static_costs < 253)
    shortened = 0
    for trial in range(60):
        costs = costmap.static_costs
        if trial % 2:  # random soft costs on top: ties and steps everywhere
            noise = rng.choice(np.array([0, 0, 40, 120, 252], dtype=np.uint8), costs.shape)
            costs = np.maximum(costs, noise)
        a, b = (free[rng.integers(0, free.shape[0])] for _ in "ab")
        start, goal = grid.cell_to_world(*a), grid.cell_to_world(*b)
        try:
            cells, _ = numpy_astar_cells(
                coarsen_costs(costs, planner.factor),
                tuple(int(v) // planner.factor for v in a),
                tuple(int(v) // planner.factor for v in b),
            )
        except PlanningError:
            continue
        rows, cols = np.array(cells, dtype=np.float64).T
        points = np.column_stack(
            (
                grid.origin_x + (cols + 0.5) * planner.coarse_resolution,
                grid.origin_y + (rows + 0.5) * planner.coarse_resolution,
            )
        )
        points[0], points[-1] = (float(start[0]), float(start[1])), (float(goal[0]), float(goal[1]))
        window = int(rng.choice([120, 5, 2]))
        ref = numpy_shortcut(points, costs, grid, window)
        assert np.array_equal(global_planner.shortcut(points, costs, grid, window), ref)
        shortened += len(ref) < len(points)
        kernel = global_planner.shortcut_kept
        args = (points, costs, float(grid.origin_x), float(grid.origin_y), grid.resolution, window)
        if trial < 6:
            assert np.array_equal(kernel(*args), jit.python_function(kernel)(*args))
    assert shortened > 20


def test_global_plans_equal_numpys_on_the_isr_floor(recorded: RecordedNavigation) -> None:
    rng = np.random.default_rng(30)
    grid = recorded.grid
    costs = Costmap(grid).static_costs
    fast, ref = GlobalPlanner(grid, recorded.config), NumpyGlobalPlanner(grid, recorded.config)
    free = np.argwhere(costs < 254)
    for _ in range(25):
        a, b = (grid.cell_to_world(*free[rng.integers(0, free.shape[0])]) for _ in "ab")
        start, goal = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
        try:
            expected = ref.plan(costs, start, goal)
        except PlanningError as exc:
            with pytest.raises(type(exc)):
                fast.plan(costs, start, goal)
            continue
        assert fast.plan(costs, start, goal) == expected


def test_obstacle_points_equal_numpys() -> None:
    rng = np.random.default_rng(31)
    for trial in range(200):
        shape = (int(rng.integers(0, 90)), int(rng.integers(0, 90)))
        window = rng.random(shape) < float(rng.choice([0.0, 0.01, 0.2, 1.0]))
        row0, col0 = (int(v) for v in rng.integers(0, 2000, 2))
        res, ox, oy = float(rng.choice([0.05, 0.02])), *(float(v) for v in rng.uniform(-40, 0, 2))
        pose = Pose2D(*rng.uniform((-30.0, -30.0, -math.pi), (30.0, 30.0, math.pi)))
        scan = _scan(rng) if trial % 2 else None
        laser_x = float(rng.uniform(0.0, 0.3))
        scan_points = None if scan is None else scan.points(max_range=2.9)
        ours = obstacle_points_near(window, row0, col0, res, ox, oy, pose, scan_points, laser_x)
        ref = numpy_obstacle_points_near(window, row0, col0, res, ox, oy, pose)
        if scan_points is not None:
            ref = np.vstack((ref, scan_points + np.array([laser_x, 0.0])))
        assert ours.shape == ref.shape and np.array_equal(ours, ref)


def _veiled_ranges(rng: np.random.Generator) -> np.ndarray:
    """Ranges with edges, veils (points between a near and a far surface) and no-returns."""
    n = 1081
    ranges = np.repeat(rng.uniform(0.3, 8.0, n // 20 + 1), 20)[:n]
    ranges += rng.normal(0.0, 0.01, n)
    veils = rng.integers(1, n - 1, 40)
    ranges[veils] = 0.5 * (ranges[veils - 1] + ranges[veils + 1]) + rng.normal(0.0, 0.3, 40)
    ranges[rng.random(n) < 0.03] = np.inf
    ranges[rng.random(n) < 0.01] = np.nan
    ranges[rng.random(n) < 0.01] = 0.0
    ranges[rng.integers(0, n - 1, 30)] = ranges[rng.integers(0, n - 1, 30)]  # equal pairs
    return ranges.astype(np.float32 if rng.random() < 0.5 else np.float64)


def test_shadow_mask_equals_numpys(recorded: RecordedNavigation) -> None:
    rng = np.random.default_rng(32)
    flagged = 0
    for _ in range(300):
        ranges = _veiled_ranges(rng)
        increment = float(rng.choice([math.radians(0.25), -math.radians(0.25), 0.01]))
        window = int(rng.choice([1, 1, 2, 3]))
        mask = shadow_mask(ranges, increment, math.radians(10.0), window)
        assert np.array_equal(
            mask, numpy_shadow_mask(ranges, increment, math.radians(10.0), window)
        )
        flagged += int(mask.sum())
    assert flagged > 3000
    scans = [
        args[2] for name, args, _ in recorded.calls if name == "update" and args[2] is not None
    ]
    assert len(scans) > 400
    for scan in scans:  # a simulated UTM-30LX's: people, glass, clutter
        ours = shadow_mask(scan.ranges, scan.angle_increment)
        assert np.array_equal(ours, numpy_shadow_mask(scan.ranges, scan.angle_increment))


def test_veil_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(33)
    r = _veiled_ranges(rng).astype(np.float64)
    forward, backward = rng.uniform(-0.1, math.pi + 0.1, (2, r.size - 1))
    compiled, plain = np.zeros(r.size, dtype=bool), np.zeros(r.size, dtype=bool)
    scan_filter.mark_veils(r, 1, forward, backward, 0.2, compiled)
    jit.python_function(scan_filter.mark_veils)(r, 1, forward, backward, 0.2, plain)
    assert np.array_equal(compiled, plain) and compiled.any()


def test_trajectory_choice_kernel_compiled_equals_plain_python() -> None:
    rng = np.random.default_rng(34)
    for _ in range(30):
        v, w = np.linspace(0.0, 0.25, 11), np.linspace(-1.0, 1.0, 21)
        x_end, y_end = rng.uniform(-0.4, 0.4, (2, 231))
        bearing = np.arctan2(rng.uniform(-1, 1, 231), rng.uniform(-1, 1, 231))
        clearance = rng.uniform(-0.1, 0.5, 231)
        clearance[rng.random(231) < 0.1] = np.inf
        admissible = rng.random(231) < float(rng.choice([0.0, 0.05, 0.9]))
        path = rng.uniform(-2.0, 2.0, (int(rng.choice([0, 1, 40])), 2))
        args = (
            v,
            w,
            1.5,
            x_end,
            y_end,
            bearing,
            clearance,
            admissible,
            0.8,
            0.1,
            path,
            1.375,
            0.25,
        )
        best = local_planner.best_trajectory(*args)
        assert best == jit.python_function(local_planner.best_trajectory)(*args)
        assert (best >= 0) == bool(admissible.any()) and (best < 0 or admissible[best])
