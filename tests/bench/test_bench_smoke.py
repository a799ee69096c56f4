"""Smoke tests of the benchmarks: every ``bench/bench_*.py`` runs with ``quick=True`` and returns
the figures `interbot bench --json` promises, finite and of the right sign. No speed is asserted
here (speed targets are checked by ``make bench``); each module runs once per session."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from interbot_cli import bench as bench_cli

BENCH_DIR = Path(__file__).resolve().parents[2] / "bench"
SHARED_LOGS = BENCH_DIR.parent.parent / "shared" / "data" / "laser_logs"

# module -> keys it must return: durations / rates (> 0) and counts or errors (>= 0).
POSITIVE = {
    "localiser": ["localiser_ms_median", "localiser_ms_p99"],
    "planner": [
        "global_plan_ms_median",
        "global_plan_ms_p99",
        "local_plan_ms_median",
        "local_plan_ms_p99",
    ],
    "sim": [
        "raycast_ms_median",
        "raycast_ms_p99",
        "raycast_building_ms_median",
        "raycast_building_ms_p99",
        "sim_step_ms_median",
        "sim_step_ms_p99",
        "sim_step_realtime_factor",
        "sim_realtime_factor",
        "stack_step_ms_median",
    ],
    "tour": ["loc_rms_m", "loc_max_m", "tour_duration_s", "tour_realtime_factor"],
    "collision_monitor": [
        "collision_monitor_ms_median",
        "collision_monitor_ms_p99",
        "assisted_teleop_ms_median",
        "collision_monitor_scans",
    ],
    "teleop_scenario": ["teleop_runs", "teleop_progress_m", "teleop_progress_unassisted_m"],
    "kidnap": ["kidnap_pairs", "kidnap_detected_fraction", "kidnap_detect_s_median"],
    "global_search": [
        "global_search_isr_ms_median",
        "global_search_isr_ms_p99",
        "global_search_isr_precompute_ms",
    ],
    "relocalise": ["relocalise_isr_cold_kidnaps", "relocalise_isr_cold_detected"],
    "record": [
        "record_offer_us_median",
        "record_offer_us_p99",
        "record_writer_pct_core",
        "record_total_pct_core",
        "record_mb_per_hour",
    ],
    "replay": ["replay_speed_x", "replay_poses_received"],
    "link": ["link_pose_samples", "link_pose_ms_median", "link_pose_ms_p99"],
    "codec": [
        "tablet_speed_encode_us_median",
        "tablet_speed_decode_us_median",
        "topic_pose_decode_us_p99",
    ],
    "fleet": ["fleet_robots_seen", "fleet_discovery_ms_median", "fleet_gone_ms_median"],
    "station_fleet": [
        "station_fleet_supervised",
        "station_fleet_tick_ms_median",
        "station_fleet_poll_ms_median",
    ],
    "reallogs": [
        "reallog_intel_revisit_rms_m",
        "reallog_intel_whole_rms_m",
        "reallog_intel_whole_ms_median",
        "reallog_freiburg079_revisit_rms_m",
        "reallog_freiburg079_whole_max_m",
    ],
    "teleop": [
        "teleop_latency_ms_p50",
        "teleop_latency_ms_p99",
        "teleop_station_to_mux_ms_p50",
        "teleop_station_to_mux_ms_p99",
        "clock_period_ms_p50",
        "clock_period_ms_p99",
        "teleop_samples",
        "station_scan_view_hz",
    ],
    "station_frame": [
        "station_frame_cpu_ms_median",
        "station_frame_cpu_ms_p99",
        "station_frame_wall_ms_median",
        "station_frame_scan_points",
    ],
    "tablet_tls": [
        "tablet_rtt_plain_ms_p50",
        "tablet_rtt_tls_ms_p50",
        "tablet_rtt_tls_ms_p99",
        "tablet_tls_connect_ms_p50",
    ],
}
NON_NEGATIVE = {
    "tour": [
        "loc_heading_rms_deg",
        "tour_completed",
        "tour_collisions",
        "tour_localisation_losses",
        "tour_loc_silent_failures",
    ],
    "reallogs": [
        "reallog_intel_whole_lost_scans",
        "reallog_intel_whole_degraded_scans",
        "reallog_intel_whole_silent_failures",
        "reallog_freiburg079_revisit_silent_failures",
        "reallog_freiburg079_revisit_silent_failures_seeds",
        "reallog_intel_whole_silent_failures_seeds",
        "reallog_all_silent_failures",
    ],
    "kidnap": ["kidnap_false_losses"],
    "teleop_scenario": [
        "teleop_collisions",
        "teleop_collisions_unassisted",
        "teleop_collisions_unprotected",
        "teleop_min_clearance_m",
    ],
    "global_search": ["global_search_isr_truth_first"],
    "relocalise": [
        "relocalise_isr_cold_wrong_relocalisations",
        "relocalise_isr_cold_help_requests",
    ],
    "record": ["record_dropped"],
    "replay": ["replay_map_drops", "replay_maps_received"],
    "teleop": ["teleop_missed", "teleop_tcp_to_station_ms_p50"],
}
# What the lead's `interbot bench --json` line must hold (the union of the modules').
REQUIRED_UNION = [
    "localiser_ms_median",
    "localiser_ms_p99",
    "loc_rms_m",
    "sim_realtime_factor",
    "global_plan_ms_median",
    "local_plan_ms_median",
    "teleop_latency_ms_p50",
    "teleop_latency_ms_p99",
    "clock_period_ms_p99",
]

_results: dict[str, dict[str, Any]] = {}


def load_bench(name: str) -> ModuleType:
    return bench_cli.load(BENCH_DIR / f"bench_{name}.py")


def quick_result(name: str) -> dict[str, Any]:
    """``bench_<name>.run(quick=True)``, run once per test session."""
    if name not in _results:
        _results[name] = bench_cli.call_run(load_bench(name), quick=True)
    return _results[name]


def test_every_bench_module_is_covered() -> None:
    found = {p.stem.removeprefix("bench_") for p in BENCH_DIR.glob("bench_*.py")}
    assert found == set(POSITIVE)


@pytest.mark.qt_log_ignore("propagateSizeHints")  # the offscreen platform's note on show()
@pytest.mark.parametrize("name", sorted(POSITIVE))
def test_quick_run_returns_finite_figures(name: str) -> None:
    if name == "reallogs" and not SHARED_LOGS.is_dir():
        assert quick_result(name) == {}
        pytest.skip(f"{SHARED_LOGS} is absent: bench_reallogs returns {{}}")
    result = quick_result(name)
    for key in POSITIVE[name]:
        assert key in result, f"bench_{name} lacks {key}"
        assert math.isfinite(result[key]) and result[key] > 0, f"{key} = {result[key]}"
    for key in NON_NEGATIVE.get(name, []):
        assert key in result, f"bench_{name} lacks {key}"
        assert math.isfinite(result[key]) and result[key] >= 0, f"{key} = {result[key]}"


@pytest.mark.qt_log_ignore("propagateSizeHints")
def test_teleop_parts_add_up() -> None:
    r = quick_result("teleop")
    assert r["teleop_samples"] + r["teleop_missed"] == 20
    # The two parts of a sample are each no longer than the whole.
    assert r["teleop_tcp_to_station_ms_p50"] <= r["teleop_latency_ms_max"]
    assert r["teleop_station_to_mux_ms_p50"] <= r["teleop_latency_ms_max"]
    # The station's clock() period is the thesis's 100 ms (its median; p99 depends on load).
    assert 80.0 < r["clock_period_ms_p50"] < 130.0


def test_quick_tour_is_the_realistic_headline_so_far() -> None:
    """The first 60 s of the realistic-world tour (bench_tour, quick): the robot drives, touches
    nothing, never loses itself, and is never silently wrong (> 0.3 m while ok)."""
    r = quick_result("tour")
    assert r["tour_stops_total"] == 15
    assert r["tour_distance_m"] > 5.0  # 60 s at up to 0.25 m/s, minus the first stop's dwell
    assert r["tour_stops_visited"] >= 1
    assert r["tour_collisions"] == 0
    assert r["tour_localisation_losses"] == 0
    assert r["tour_loc_silent_failures"] == 0
    assert 0.0 < r["loc_rms_m"] <= r["loc_max_m"] < 0.3
    assert r["tour_min_clearance_m"] > 0.0
    assert r["tour_completed"] == 0.0  # 60 s cannot finish a 15-stop tour


def test_quick_sim_figures_are_consistent() -> None:
    r = quick_result("sim")
    assert r["raycast_ms_median"] <= r["raycast_ms_p99"]
    assert r["raycast_building_ms_median"] <= r["raycast_building_ms_p99"]
    assert r["sim_step_ms_median"] <= r["sim_step_ms_p99"]
    assert r["sim_realtime_span_s"] == pytest.approx(10.0, abs=0.1)


@pytest.mark.qt_log_ignore("propagateSizeHints")
def test_merged_figures_hold_the_required_keys() -> None:
    merged: dict[str, Any] = {}
    for name in sorted(POSITIVE):
        if name == "reallogs" and not SHARED_LOGS.is_dir():
            continue
        merged.update(quick_result(name))
    missing = [key for key in REQUIRED_UNION if key not in merged]
    assert not missing


def test_link_latency_is_plausible_plain_and_secure() -> None:
    """One-way pose latency on loopback (plain TCP, and mutual TLS + ACL, issue 15)."""
    r = quick_result("link")
    assert r["link_pose_samples"] == 30.0
    assert 0.0 < r["link_pose_ms_median"] <= r["link_pose_ms_p99"] <= r["link_pose_ms_max"] < 1e3
    secure = bench_cli.call_run(load_bench("link"), quick=True, secure=True)
    assert secure["link_pose_samples"] == 30.0 and 0.0 < secure["link_pose_ms_median"] < 1e3


def test_summary_ms_percentiles_and_empty() -> None:
    module = _load_common()
    out = module.summary_ms(np.arange(1, 101) * 1e-3, "x")  # 1..100 ms
    assert out["x_ms_median"] == pytest.approx(50.5)
    assert out["x_ms_p99"] == pytest.approx(99.01)
    assert out["x_ms_max"] == pytest.approx(100.0)
    named = module.summary_ms([0.002], "y", median_name="p50")
    assert set(named) == {"y_ms_p50", "y_ms_p99", "y_ms_max"}
    assert all(math.isnan(v) for v in module.summary_ms([], "z").values())


def test_quiet_logs_raises_and_restores_levels() -> None:
    module = _load_common()
    daemon_logger = logging.getLogger("robot_daemon")
    before = daemon_logger.level
    with module.quiet_logs():
        assert daemon_logger.level == logging.WARNING
        assert not logging.getLogger("robot_daemon.stack").isEnabledFor(logging.INFO)
    assert daemon_logger.level == before


def _load_common() -> ModuleType:
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_common_test", BENCH_DIR / "_common.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
