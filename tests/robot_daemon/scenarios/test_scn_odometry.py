"""Test Scenario 1 on a small corridor: error rates near the odometry models' 8 % / 3 %."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from interbot_core.topological_map import TopologicalMap
from robot_daemon.scenarios.odometry import (
    CircuitDriver,
    OdometryScenarioError,
    choose_stretch,
    error_rate,
    expected_duration,
    summarise,
)
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, straight_segments


def _write_world(tmp_path: Path) -> ScenarioOptions:
    res = 0.05
    cells = np.full((round(3.0 / res), round(12.0 / res)), OCCUPIED, dtype=np.int8)
    cells[round(0.5 / res) : round(2.5 / res), round(0.5 / res) : round(11.5 / res)] = FREE
    OccupancyGrid(cells, res, 0.0, 0.0).save(tmp_path / "small.yaml")
    data = {
        "map": "small.yaml",
        "nodes": [
            {"id": 0, "name": "West", "x": 1.5, "y": 1.5, "yaw": 0.0},
            {"id": 1, "name": "East", "x": 10.5, "y": 1.5, "yaw": 0.0},
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


def test_expected_duration_is_eq_6_1_and_6_2() -> None:
    assert expected_duration(26.0, 0.6) == pytest.approx(43.333, abs=1e-3)
    assert expected_duration(2 * math.pi, 0.6) == pytest.approx(10.472, abs=1e-3)
    assert error_rate(43.333, 40.0) == pytest.approx(0.0769, abs=1e-4)  # Table 6.1 row 1


def test_stretch_is_the_longest_segment_and_d_fits(tmp_path: Path) -> None:
    options = _write_world(tmp_path)
    system = SimulatedSystem(options, start_node=0)
    segments = straight_segments(system.grid, system.topo, min_clearance=0.7)
    assert [s.nodes for s in segments] == [(0, 1)]
    start, distance = choose_stretch(segments)
    assert distance == pytest.approx(7.0)  # 9 m less 1 m at each end (26 m does not fit)
    assert (start.x, start.y) == pytest.approx((2.5, 1.5))
    with pytest.raises(OdometryScenarioError, match="no straight"):
        choose_stretch([])


@pytest.mark.parametrize(
    ("model", "low", "high"), [("uncalibrated", 5.5, 8.5), ("calibrated", 2.5, 5.0)]
)
def test_error_rates_near_the_model(tmp_path: Path, model: str, low: float, high: float) -> None:
    options = dataclasses.replace(_write_world(tmp_path), odometry=model)
    start = Pose2D(2.5, 1.5, 0.0)
    system = SimulatedSystem(options, start_pose=start)
    system.localise()
    driver = CircuitDriver(system, start, 7.0)
    out = driver.linear(1, 1, 0.3, start)
    back = Pose2D(9.5, 1.5, math.pi)
    turn = driver.rotation(1, 2, 0.6, back.yaw)
    assert low <= 100 * out.error <= high
    assert low - 1.0 <= 100 * turn.error <= high
    assert system.sim.collisions == 0
    # The encoders under-report (uncalibrated) or over-report (calibrated) the truth.
    ratio = out.odometry_at_target / out.target
    assert ratio == pytest.approx(0.923 if model == "uncalibrated" else 1.03, abs=0.01)
    rows = summarise([out, turn])
    assert {r["kind"] for r in rows} == {"linear", "angular"}
    # The robot faces back along the corridor after the untimed turn-around.
    assert abs(math.remainder(system.sim.true_pose().yaw - math.pi, 2 * math.pi)) < 0.1
