"""Benchmark: the collision monitor's cost per scan, and assisted teleoperation's per command.

Scans are real simulated UTM-30LX scans (1081 beams, 270 degrees) taken by the simulator on
ISR floor 0 with people walking, at 200 poses spread over the map's free space (corridors,
rooms, doorways; seed 1). Per scan, ``collision_monitor_ms_*`` times what the robot does when a
scan arrives and the multiplexer's output goes to the motors: `CollisionMonitor.on_scan` (returns
to base_link, every zone re-evaluated with hysteresis) plus one `update` for a moving command
(0.5 m/s, 0.4 rad/s: the approach zone simulates the arc). ``assisted_teleop_ms_*`` times one
`AssistedTeleop.assist` (13 arcs) for a forward push on the same scans. Target: monitor median
<= 0.5 ms.

    .venv/bin/interbot bench --only collision_monitor --json
"""

from __future__ import annotations

import importlib.util
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import load_map
from robot_daemon.safety.assisted_teleop import AssistedTeleop
from robot_daemon.safety.collision_monitor import CollisionMonitor
from robot_daemon.safety.motion_guard import default_guard_config
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.stack import DEFAULT_LASER_MOUNT

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SEED = 1


def _scans(count: int) -> list[Any]:
    grid = load_map(common.ISR_MAP)
    sim = Simulator(grid, SimConfig(n_people=6), rng_seed=SEED)
    rng = np.random.default_rng(SEED)
    free = np.argwhere(~grid.blocked())
    scans = []
    while len(scans) < count:
        row, col = free[rng.integers(len(free))]
        x, y = grid.cell_to_world(int(row), int(col))
        pose = Pose2D(float(x), float(y), float(rng.uniform(-np.pi, np.pi)))
        if sim.world.footprint_hits_wall(sim.config.footprint, pose):
            continue
        sim.teleport(pose)
        sim.step(0.05)
        scans.append(sim.scan())
    return scans


def run(quick: bool = False) -> dict[str, Any]:
    with common.quiet_logs():
        scans = _scans(40 if quick else 200)
    config = default_guard_config()
    monitor = CollisionMonitor(config.monitor, DEFAULT_LASER_MOUNT)
    assist = AssistedTeleop(config.assist)
    repeats = 2 if quick else 5
    monitor_s: list[float] = []
    assist_s: list[float] = []
    for _ in range(repeats):
        for k, scan in enumerate(scans):
            now = 0.1 * k
            t0 = time.perf_counter()
            monitor.on_scan(scan, now)
            monitor.update(0.5, 0.4, now)
            t1 = time.perf_counter()
            px, py = monitor.points
            assist.assist(0.5, 0.0, px, py)
            t2 = time.perf_counter()
            monitor_s.append(t1 - t0)
            assist_s.append(t2 - t1)
    return {
        **common.summary_ms(monitor_s, "collision_monitor"),
        **common.summary_ms(assist_s, "assisted_teleop"),
        "collision_monitor_scans": float(len(monitor_s)),
    }


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
