"""Benchmark: the simulator's cost, alone and with the whole robot stack on simulated time.

* ``raycast_ms_median`` / ``_p99``: one 1081-beam UTM-30LX scan (walls of the ISR floor map plus
  three people) by `robot_daemon.sim.laser_sim.bench_raycast`, from random free poses.
* ``raycast_building_ms_median`` / ``_p99``: the same scan in the simulated building of the
  realistic world (`robot_daemon.sim.realistic_world`, the ISR plan redrawn at 2 cm, seed 1).
* ``sim_step_ms_median`` / ``_p99``: one `Simulator.step` of the daemon's 20 ms loop period
  (drive, collisions, odometry, four people), without sensing.
* ``sim_step_realtime_factor``: simulated seconds per wall second of the simulator alone
  (`robot_daemon.sim.simulator.bench_step`: 100 Hz steps, scans at the stack's 10 Hz).
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

from interbot_core.occupancy_grid import load_map
from interbot_core.supervisor import GuidedTour
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour
from robot_daemon.scenarios.tour import STOP_DWELL_S
from robot_daemon.sim.laser_sim import bench_raycast
from robot_daemon.sim.realistic_world import build_sim_world, plan_beside
from robot_daemon.sim.simulator import SimConfig, Simulator, bench_step

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
        ray = bench_raycast(grid, n_scans=20 if quick else 300, seed=SEED)
        out["raycast_ms_median"] = ray["median_ms"]
        out["raycast_ms_p99"] = ray["p99_ms"]
        building = build_sim_world(
            grid, np.random.default_rng(SEED), plan_yaml=plan_beside(common.ISR_MAP)
        ).grid
        ray = bench_raycast(building, n_scans=20 if quick else 300, seed=SEED)
        out["raycast_building_ms_median"] = ray["median_ms"]
        out["raycast_building_ms_p99"] = ray["p99_ms"]
        out.update(common.summary_ms(time_sim_steps(100 if quick else 2000), "sim_step"))
        alone = bench_step(grid, sim_seconds=2.0 if quick else 30.0, n_people=4, scan_hz=10.0)
        out["sim_step_realtime_factor"] = alone["realtime_factor"]
        factor, passes, span = time_whole_stack(QUICK_TOUR_SPAN_S if quick else TOUR_SPAN_S)
        out["sim_realtime_factor"] = factor
        out["sim_realtime_span_s"] = span
        out.update(common.summary_ms(passes, "stack_step"))
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
