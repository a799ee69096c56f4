"""Benchmark: global plan and local (DWA) cycle times of robot_daemon.planning.

Targets: a corridor-to-far-room global plan on the 70 x 35 m ISR floor <= 100 ms median (Nav2's
NavFn: ~146 ms for a 75 m path in C++); a local planner cycle <= 10 ms median (DWB: ~3 ms in
C++). Maps: the Willow Garage map (../shared/data/maps/willow.yaml, corner to corner) and
maps/isr_floor0.yaml (Main Entrance to the inside of the Mecatronics Lab and to the NE corner),
each when present. Timing uses time.perf_counter here only, never inside the libraries.

The local figure is one full controller cycle of the navigator's local part: gather the costmap's
obstacle cells around the robot plus a 1081-beam scan, build the robot-centred distance field and
run the 11 x 21 x 15-step DWA. ``navigator_update_ms_median`` is a whole ``Navigator.update``
(costmap marking/clearing with the scan, DWA, and the 1 Hz replan amortised).

    .venv/bin/python bench/bench_planner.py
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import (
    UTM30LX_ANGLE_INCREMENT,
    UTM30LX_ANGLE_MIN,
    UTM30LX_BEAMS,
    UTM30LX_RANGE_MAX,
    UTM30LX_RANGE_MIN,
    LaserScan,
)
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import Costmap
from robot_daemon.planning.global_planner import GlobalPlanner
from robot_daemon.planning.local_planner import DWAPlanner, obstacle_points_near
from robot_daemon.planning.navigator import Navigator

REPO = Path(__file__).resolve().parent.parent
WILLOW = REPO.parent / "shared" / "data" / "maps" / "willow.yaml"
ISR = REPO / "maps" / "isr_floor0.yaml"
ISR_TOPO = REPO / "maps" / "isr_floor0_topo.yaml"


def _ms(samples: list[float]) -> tuple[float, float]:
    a = np.asarray(samples) * 1e3
    return float(np.median(a)), float(np.percentile(a, 99))


def cast_scan(grid: OccupancyGrid, pose: Pose2D, now: float) -> LaserScan:
    """A UTM-30LX scan (1081 beams) ray-cast in ``grid``, capped at 10 m for speed."""
    angles = UTM30LX_ANGLE_MIN + UTM30LX_ANGLE_INCREMENT * np.arange(UTM30LX_BEAMS)
    t = np.arange(0.0, 10.0, 0.5 * grid.resolution)
    xs = pose.x + np.cos(angles + pose.yaw)[:, None] * t[None, :]
    ys = pose.y + np.sin(angles + pose.yaw)[:, None] * t[None, :]
    rows, cols = grid.world_to_cell(xs, ys)
    inside = grid.in_bounds(rows, cols)
    hit = np.ones(xs.shape, dtype=bool)
    hit[inside] = grid.blocked()[rows[inside], cols[inside]]
    first = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
    ranges = np.where(first >= 0, t[np.maximum(first, 0)], np.inf).astype(np.float32)
    return LaserScan(
        now,
        UTM30LX_ANGLE_MIN,
        UTM30LX_ANGLE_INCREMENT,
        UTM30LX_RANGE_MIN,
        UTM30LX_RANGE_MAX,
        ranges,
    )


def willow_pairs(grid: OccupancyGrid, costs: npt.NDArray[np.uint8]) -> list[tuple[tuple[float, float], tuple[float, float]]]:  # fmt: skip
    free = np.argwhere(costs == 0)
    order = free.sum(axis=1)
    a, b = free[np.argmin(order)], free[np.argmax(order)]
    start = tuple(float(v) for v in grid.cell_to_world(*a))
    goal = tuple(float(v) for v in grid.cell_to_world(*b))
    return [(start, goal), (goal, start)]  # type: ignore[list-item]


def isr_pairs() -> list[tuple[tuple[float, float], tuple[float, float]]]:
    nodes = {n["name"]: (float(n["x"]), float(n["y"])) for n in yaml.safe_load(ISR_TOPO.read_text())["nodes"]}  # fmt: skip
    entrance = nodes["Main Entrance"]
    far = [nodes[name] for name in ("Mecatronics Lab", "NE corner") if name in nodes]
    if not far:
        far = [max(nodes.values(), key=lambda p: math.dist(p, entrance))]
    return [(entrance, f) for f in far]


def time_global(grid: OccupancyGrid, pairs: list[Any], repeats: int) -> tuple[list[float], list[float]]:  # fmt: skip
    costs = Costmap(grid).costs(0.0)
    planner = GlobalPlanner(grid)
    times: list[float] = []
    lengths: list[float] = []
    for start, goal in pairs:
        planner.plan(costs, start, goal)  # warm-up
        for _ in range(repeats):
            t0 = time.perf_counter()
            path = planner.plan(costs, start, goal)
            times.append(time.perf_counter() - t0)
        lengths.append(float(np.hypot(*np.diff(np.asarray(path), axis=0).T).sum()))
    return times, lengths


def time_local(grid: OccupancyGrid, start: tuple[float, float], goal: tuple[float, float], cycles: int) -> tuple[list[float], list[float]]:  # fmt: skip
    """Local cycles while driving the path with a perfect kinematic robot."""
    config = PlannerConfig()
    costmap = Costmap(grid, config)
    path = np.asarray(GlobalPlanner(grid, config).plan(costmap.costs(0.0), start, goal))  # fmt: skip
    dwa = DWAPlanner(config)
    heading = math.atan2(path[3, 1] - path[0, 1], path[3, 0] - path[0, 0])
    pose, command = Pose2D(start[0], start[1], heading), (0.0, 0.0)
    local_times: list[float] = []
    half = dwa.field_half_size()
    k = math.ceil(half * math.sqrt(2.0) / grid.resolution) + 1
    for i in range(cycles):
        scan = cast_scan(grid, pose, 0.1 * i)
        t0 = time.perf_counter()
        row, col = (int(v) for v in grid.world_to_cell(pose.x, pose.y))
        window = costmap.obstacles_window(0.1 * i, row - k, row + k + 1, col - k, col + k + 1)
        pts = obstacle_points_near(window, max(row - k, 0), max(col - k, 0), grid.resolution, grid.origin_x, grid.origin_y, pose)  # fmt: skip
        pts = np.vstack((pts, scan.points(max_range=2.0 * half)))
        plan = dwa.compute(pose, command, path, dwa.make_field(pts), 0.1, pose.distance_to(Pose2D(goal[0], goal[1], 0.0)))  # fmt: skip
        local_times.append(time.perf_counter() - t0)
        command = (plan.linear, plan.angular)
        w = plan.angular
        if abs(w) < 1e-12:
            delta = Pose2D(plan.linear * 0.1, 0.0, 0.0)
        else:
            delta = Pose2D(plan.linear / w * math.sin(w * 0.1), plan.linear / w * (1 - math.cos(w * 0.1)), w * 0.1)  # fmt: skip
        pose = pose.compose(delta)
    # Whole navigator updates on the same route (scan integration, replans at 1 Hz included).
    nav = Navigator(grid, config)
    nav.set_route([Pose2D(goal[0], goal[1], 0.0)], now=0.0)
    pose = Pose2D(start[0], start[1], heading)
    nav_times: list[float] = []
    for i in range(cycles):
        scan = cast_scan(grid, pose, 0.1 * i)
        t0 = time.perf_counter()
        cmd = nav.update(0.1 * i, pose, scan)
        nav_times.append(time.perf_counter() - t0)
        w = cmd.angular
        if abs(w) < 1e-12:
            delta = Pose2D(cmd.linear * 0.1, 0.0, 0.0)
        else:
            delta = Pose2D(cmd.linear / w * math.sin(w * 0.1), cmd.linear / w * (1 - math.cos(w * 0.1)), w * 0.1)  # fmt: skip
        pose = pose.compose(delta)
    return local_times, nav_times


def run(quick: bool = False) -> dict[str, Any]:
    repeats = 3 if quick else 15
    cycles = 40 if quick else 200
    results: dict[str, Any] = {}
    all_global: list[float] = []
    local_grid: OccupancyGrid | None = None
    local_pair: tuple[tuple[float, float], tuple[float, float]] | None = None
    if ISR.exists() and ISR_TOPO.exists():
        grid = load_map(ISR)
        pairs = isr_pairs()
        times, lengths = time_global(grid, pairs, repeats)
        results["isr_global_plan_ms_median"], results["isr_global_plan_ms_p99"] = _ms(times)
        results["isr_path_length_m_max"] = max(lengths)
        all_global += times
        local_grid, local_pair = grid, pairs[0]
    if WILLOW.exists():
        grid = load_map(WILLOW)
        pairs = willow_pairs(grid, Costmap(grid).costs(0.0))
        times, lengths = time_global(grid, pairs, repeats)
        results["willow_global_plan_ms_median"], results["willow_global_plan_ms_p99"] = _ms(times)
        results["willow_path_length_m"] = max(lengths)
        all_global += times
        if local_grid is None:
            local_grid, local_pair = grid, pairs[0]
    if not all_global or local_grid is None or local_pair is None:
        raise FileNotFoundError(f"neither {ISR} nor {WILLOW} exists: nothing to benchmark")
    results["global_plan_ms_median"], results["global_plan_ms_p99"] = _ms(all_global)
    local_times, nav_times = time_local(local_grid, local_pair[0], local_pair[1], cycles)
    results["local_plan_ms_median"], results["local_plan_ms_p99"] = _ms(local_times)
    results["navigator_update_ms_median"], results["navigator_update_ms_p99"] = _ms(nav_times)
    return results


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
