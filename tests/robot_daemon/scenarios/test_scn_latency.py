"""The latency scenario on a small corridor: mux timeouts only when delays exceed the timeout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from interbot_core.topological_map import TopologicalMap
from robot_daemon.scenarios.latency import LatencyConfig, lay_out_run, run_trial
from robot_daemon.scenarios.runner import ScenarioOptions, StraightSegment
from robot_daemon.sim.wifi import WifiConfig

IDEAL = WifiConfig(0.001, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)  # a wired-like link: 1 ms, never bad


def _write_world(tmp_path: Path) -> ScenarioOptions:
    res = 0.05
    cells = np.full((round(3.0 / res), round(10.0 / res)), OCCUPIED, dtype=np.int8)
    cells[round(0.5 / res) : round(2.5 / res), round(0.5 / res) : round(9.5 / res)] = FREE
    OccupancyGrid(cells, res, 0.0, 0.0).save(tmp_path / "small.yaml")
    data = {
        "map": "small.yaml",
        "nodes": [
            {"id": 0, "name": "Entrance", "x": 1.5, "y": 1.5, "yaw": 0.0},
            {"id": 1, "name": "Library", "x": 8.5, "y": 1.5, "yaw": 0.0},
        ],
        "arcs": [[0, 1]],
    }
    TopologicalMap.from_dict(data, "small_topo.yaml", tmp_path)
    (tmp_path / "small_topo.yaml").write_text(yaml.safe_dump(data), encoding="utf-8")
    # The scenario's own logic on a tiny synthetic corridor: world = map (the realistic world
    # of issue 12 is exercised by test_scn_tour.py and the benchmarks).
    return ScenarioOptions(
        map_yaml=tmp_path / "small.yaml",
        topo_yaml=tmp_path / "small_topo.yaml",
        people=0,
        ideal_world=True,
    )


def test_run_is_laid_so_section_2_is_at_the_zone() -> None:
    seg = StraightSegment((0.0, 0.0), (30.0, 0.0), 1.2, (0, 1))
    start, length, _ = lay_out_run([seg], (5.0, 0.0), 20.0)
    assert length == 20.0
    assert (start.x, start.yaw) == pytest.approx((25.0, 3.14159), abs=1e-4)  # west, ends at x=5
    start, _, _ = lay_out_run([seg], (26.0, 0.0), 20.0)
    assert (start.x, start.yaw) == pytest.approx((6.0, 0.0))


def _config(wifi: WifiConfig, **kw: float) -> LatencyConfig:
    return LatencyConfig(distance=2.0, runs=1, wifi=wifi, zone_radius=1.0, **kw)


def test_ideal_link_no_timeouts_regular_periods(tmp_path: Path) -> None:
    options = _write_world(tmp_path)
    trial = run_trial(options, "Base Station", 1, _config(IDEAL, zone_p_good_to_bad=0.0))
    row = trial.row(1)
    assert row["mux_timeouts"] == 0
    assert row["received"] == row["sent"] > 100
    assert all(
        abs(s["mean_ms"] - 100.0) < 0.5 and s["std_ms"] < 1.0 for s in row["sections"].values()
    )
    assert trial.points_over_1s == []
    assert trial.collisions == 0


def test_delays_below_the_timeout_do_not_fire_it(tmp_path: Path) -> None:
    options = _write_world(tmp_path)
    wifi = WifiConfig(p_good_to_bad=0.05, bad_delay_min=0.2, bad_delay_max=0.3, handover_max=0.3)
    trial = run_trial(options, "Base Station", 2, _config(wifi, mux_timeout=0.5))
    assert trial.max_delay > 0.2  # the link was bad at times ...
    assert trial.row(1)["mux_timeouts"] == 0  # ... but never beyond the 0.5 s timeout


def test_delays_above_the_timeout_fire_it_and_the_watchdog_discards(tmp_path: Path) -> None:
    options = _write_world(tmp_path)
    wifi = WifiConfig(p_good_to_bad=0.02, bad_delay_min=0.8, bad_delay_max=1.5)
    trial = run_trial(options, "Tablet", 3, _config(wifi, mux_timeout=0.2))
    row = trial.row(1)
    assert row["mux_timeouts"] > 0
    assert row["watchdog_discards"] > 0
    assert row["received"] == row["sent"] - row["watchdog_discards"]
    assert len(trial.points_over_1s) > 0
