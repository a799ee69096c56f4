"""Benchmark: the guided tour (Test Scenario 2, thesis §6.2, Table 6.4) with people, seed 1.

Runs `robot_daemon.scenarios.tour.run` headless on simulated time (simulator, localiser,
planner, multiplexer and the station's supervisor in one process) and reports its figures from
the simulator's ground truth: localisation error (RMS / max, heading RMS), silent localisation
failures (10 Hz samples reported ok while > 0.3 m or 10 degrees off), completion, collisions,
localisation losses, duration and the real-time factor (simulated seconds per wall second,
excluding start-up; ``tour_cpu_realtime_factor`` per CPU second of the process, which other
processes on a shared machine do not inflate).

The tour runs in the REALISTIC world (`robot_daemon.sim.realistic_world`: the simulator's own
building, not the map; UTM-30LX errors; odometry slip; hand-set initial pose). A full run also
reports, for comparison, the same tour in the ideal world (world = map, exact initial pose) as
``tour_ideal_*`` and the tours of the two real buildings' graphs (``maps/willow_topo.yaml``,
``maps/fetch_office_topo.yaml``, maps in ../shared/data) as ``tour_willow_*`` and
``tour_fetch_*``. ``quick`` stops the realistic ISR tour after 60 s of simulated time (a smoke
run; ``tour_completed`` is then 0) and skips the others.

    .venv/bin/interbot bench --only tour --json
"""

from __future__ import annotations

import dataclasses
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
    "loc_silent_failures": "tour_loc_silent_failures",
    "completed": "tour_completed",
    "collisions": "tour_collisions",
    "localisation_losses": "tour_localisation_losses",
    "duration_s": "tour_duration_s",
    "realtime_factor": "tour_realtime_factor",
    "cpu_realtime_factor": "tour_cpu_realtime_factor",
    "stops_visited": "tour_stops_visited",
    "stops_total": "tour_stops_total",
    "distance_m": "tour_distance_m",
    "mean_speed_mps": "tour_mean_speed_mps",
    "min_clearance_m": "tour_min_clearance_m",
    # The error split (`robot_daemon.scenarios.map_echo`; realistic worlds only): the map's own
    # error where the robot was, the localiser's relative to it; the covariance's NEES per dof.
    "loc_echo_rms_m": "tour_loc_echo_rms_m",
    "loc_own_rms_m": "tour_loc_own_rms_m",
    "loc_own_max_m": "tour_loc_own_max_m",
    "loc_nees_per_dof": "tour_loc_nees_per_dof",
}


# Tours of the real buildings: (prefix, map YAML, topological map), maps from ../shared/data.
_MAPS = common.SHARED_DATA / "maps"
REAL_BUILDINGS = (
    ("tour_willow", _MAPS / "willow.yaml", common.REPO / "maps" / "willow_topo.yaml"),
    ("tour_fetch", _MAPS / "fetch_office.yaml", common.REPO / "maps" / "fetch_office_topo.yaml"),
)


def _figures(options: ScenarioOptions, prefix: str) -> dict[str, Any]:
    with common.quiet_logs():
        figures = tour.run(options).figures
    out: dict[str, Any] = {}
    for name, key in _KEYS.items():
        if name not in figures:  # the error split: not in the ideal world (world = map)
            continue
        out[key if prefix == "tour" else f"{prefix}_{key.removeprefix('tour_')}"] = float(
            figures[name]
        )
    if not figures["completed"]:
        out[f"{prefix}_failure"] = str(figures["reason"])  # why, in the table (not a number)
    return out


def run(quick: bool = False) -> dict[str, Any]:
    options = ScenarioOptions(seed=SEED, max_sim_time=QUICK_SPAN_S if quick else FULL_LIMIT_S)
    out = _figures(options, "tour")
    if quick:
        out.pop("tour_failure", None)  # a 60 s smoke run does not finish the tour
        return out
    out.update(_figures(dataclasses.replace(options, ideal_world=True), "tour_ideal"))
    for prefix, map_yaml, topo_yaml in REAL_BUILDINGS:
        if map_yaml.exists():
            out.update(
                _figures(
                    dataclasses.replace(options, map_yaml=map_yaml, topo_yaml=topo_yaml), prefix
                )
            )
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
