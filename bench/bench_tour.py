"""Benchmark: the guided tour (Test Scenario 2, thesis §6.2, Table 6.4) with people, seed 1.

Runs `robot_daemon.scenarios.tour.run` headless on simulated time (simulator, localiser,
planner, multiplexer and the station's supervisor in one process) and reports its figures from
the simulator's ground truth: localisation error (RMS / max, heading RMS), completion,
collisions, localisation losses, duration and the real-time factor (simulated seconds per wall
second, including start-up). ``quick`` stops the tour after 60 s of simulated time (a smoke run;
``tour_completed`` is then 0).

    .venv/bin/interbot bench --only tour --json
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

from robot_daemon.scenarios import tour
from robot_daemon.scenarios.runner import ScenarioOptions

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SEED = 1
QUICK_SPAN_S = 60.0  # [s] simulated time of the quick run
FULL_LIMIT_S = 3600.0  # [s] the scenario's own time limit

# tour figure -> benchmark key
_KEYS = {
    "loc_rms_m": "loc_rms_m",
    "loc_max_m": "loc_max_m",
    "loc_heading_rms_deg": "loc_heading_rms_deg",
    "completed": "tour_completed",
    "collisions": "tour_collisions",
    "localisation_losses": "tour_localisation_losses",
    "duration_s": "tour_duration_s",
    "realtime_factor": "tour_realtime_factor",
    "stops_visited": "tour_stops_visited",
    "stops_total": "tour_stops_total",
    "distance_m": "tour_distance_m",
    "mean_speed_mps": "tour_mean_speed_mps",
    "min_clearance_m": "tour_min_clearance_m",
}


def run(quick: bool = False) -> dict[str, Any]:
    options = ScenarioOptions(seed=SEED, max_sim_time=QUICK_SPAN_S if quick else FULL_LIMIT_S)
    with common.quiet_logs():
        result = tour.run(options)
    figures = result.figures
    out = {key: float(figures[name]) for name, key in _KEYS.items()}
    if not quick and not figures["completed"]:
        out["tour_failure"] = str(figures["reason"])  # why, in the table (not a number)
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
