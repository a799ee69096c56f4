"""Benchmark: the simulator's cost, alone and with the whole robot stack on simulated time.

* ``raycast_ms_median`` / ``_p99``: one 1081-beam UTM-30LX scan (walls of the ISR floor map plus
  three people) by `robot_daemon.sim.laser_sim.LaserSim` (`time_raycast`), from random free poses.
* ``raycast_building_ms_median`` / ``_p99``: the same scan in the simulated building of the
  realistic world (`robot_daemon.sim.realistic_world`, the ISR plan redrawn at 2 cm, seed 1).
* ``sim_step_ms_median`` / ``_p99``: one `Simulator.step` of the daemon's 20 ms loop period
  (drive, collisions, odometry, four people), without sensing.
* ``sim_step_realtime_factor``: simulated seconds per wall second of the simulator alone
  (`time_sim_alone`: 100 Hz steps, scans at the stack's 10 Hz).
* ``sim_realtime_factor``: the WHOLE stack (simulator, localiser, planner, multiplexer and the
  station's supervisor: `robot_daemon.scenarios.runner.SimulatedSystem`, realistic world by
  default) driving the guided tour with people (seed 1) for a fixed simulated span, 300 s (quick: 10 s), on one process;
  set-up (map loading, route planning) excluded. ``stack_step_ms_*`` is one pass of that loop.

    .venv/bin/interbot bench --only sim --json
"""

from __future__ import annotations

import gc
import importlib.util
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.supervisor import GuidedTour
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour
from robot_daemon.scenarios.tour import STOP_DWELL_S
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim
from robot_daemon.sim.realistic_world import build_sim_world, plan_beside
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.sim.world import World

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SEED = 1
TOUR_SPAN_S = 300.0  # [s] simulated time of the whole-stack run
QUICK_TOUR_SPAN_S = 10.0
DAEMON_DT = 0.02  # [s] the daemon's loop period


def time_sim_steps(n_steps: int) -> list[float]:
    """Wall time [s] of each of ``n_steps`` simulator steps of ``DAEMON_DT`` on the ISR floor."""
    sim = Simulator(load_map(common.ISR_MAP), SimConfig(n_people=4), rng_seed=SEED)
    times: list[float] = []
    for k in range(n_steps):
        sim.set_cmd_vel(0.4, 0.5 * math.sin(k / 100))
        t0 = time.perf_counter()
        sim.step(DAEMON_DT)
        times.append(time.perf_counter() - t0)
    return times


def time_raycast(grid: OccupancyGrid, n_scans: int, seed: int = 0) -> list[float]:
    """Wall time [s] of full 1081-beam scans (walls + 3 people) from random free poses."""
    world = World(grid)
    rng = np.random.default_rng(seed)
    laser = LaserSim(world, LaserConfig(), rng)
    free = np.argwhere(world.edt_cells * world.resolution > 0.5)
    picks = free[rng.integers(0, len(free), n_scans)]
    times: list[float] = []
    for row, col in picks:
        x, y = world.grid.cell_to_world(row - 2, col - 2)
        pose = Pose2D(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
        circles = np.column_stack(
            (pose.x + rng.uniform(-3, 3, 3), pose.y + rng.uniform(-3, 3, 3), np.full(3, 0.25))
        )
        start = time.perf_counter()
        laser.scan(pose, 0.0, circles)
        times.append(time.perf_counter() - start)
    return times


def time_sim_alone(grid: OccupancyGrid, sim_seconds: float, n_people: int = 4) -> float:
    """Simulated seconds per wall second stepping at 100 Hz and scanning at 10 Hz."""
    sim = Simulator(grid, SimConfig(n_people=n_people), SEED)
    steps = round(sim_seconds / 0.01)
    start = time.perf_counter()
    for k in range(steps):
        sim.set_cmd_vel(0.4, 0.5 * math.sin(k / 200))
        sim.step(0.01)
        if k % 10 == 0:
            sim.scan()
    return sim.time / (time.perf_counter() - start)


def time_whole_stack(span_s: float) -> tuple[float, list[float], float]:
    """(simulated seconds per wall second, per-pass wall times [s], simulated span [s])."""
    system = SimulatedSystem(ScenarioOptions(seed=SEED))
    system.hooks.append(auto_resume_tour(STOP_DWELL_S))
    system.localise()
    system.apply(system.supervisor.submit(GuidedTour()))
    steps: list[float] = []
    start_sim = system.now
    limit = start_sim + span_s
    gc.collect()
    t_start = time.perf_counter()
    while system.now < limit:
        t0 = time.perf_counter()
        system.step()
        steps.append(time.perf_counter() - t0)
    wall = time.perf_counter() - t_start
    simulated = system.now - start_sim
    return simulated / wall, steps, simulated


def run(quick: bool = False) -> dict[str, Any]:
    out: dict[str, Any] = {}
    with common.quiet_logs():
        grid = load_map(common.ISR_MAP)
        n_scans = 20 if quick else 300
        out.update(common.summary_ms(time_raycast(grid, n_scans, SEED), "raycast"))
        building = build_sim_world(
            grid, np.random.default_rng(SEED), plan_yaml=plan_beside(common.ISR_MAP)
        ).grid
        out.update(common.summary_ms(time_raycast(building, n_scans, SEED), "raycast_building"))
        out.update(common.summary_ms(time_sim_steps(100 if quick else 2000), "sim_step"))
        out["sim_step_realtime_factor"] = time_sim_alone(grid, 2.0 if quick else 30.0)
        factor, passes, span = time_whole_stack(QUICK_TOUR_SPAN_S if quick else TOUR_SPAN_S)
        out["sim_realtime_factor"] = factor
        out["sim_realtime_span_s"] = span
        out.update(common.summary_ms(passes, "stack_step"))
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
