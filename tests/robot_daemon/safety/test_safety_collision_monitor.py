"""The collision monitor on synthetic scans: stop zone, slowdown, approach along arcs (including
a turn on the spot), hysteresis, stale data, and its configuration's validation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from robot_daemon.safety.collision_monitor import (
    CollisionMonitor,
    CollisionMonitorConfig,
    SafetyConfigError,
    ZoneConfig,
)
from robot_daemon.safety.motion_guard import DEFAULT_SAFETY_YAML, load_safety_config

MOUNT = Pose2D(0.2, 0.0, 0.0)


def scan_of(points: list[tuple[float, float]] | np.ndarray, stamp: float = 0.0) -> LaserScan:
    """A 1081-beam scan whose returns are the base_link ``points`` (nearest per beam)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    lx, ly = pts[:, 0] - MOUNT.x, pts[:, 1] - MOUNT.y
    inc = math.radians(0.25)
    a_min = -math.radians(135)
    ranges = np.full(1081, np.inf, dtype=np.float32)
    beam = np.round((np.arctan2(ly, lx) - a_min) / inc).astype(int)
    ok = (beam >= 0) & (beam < 1081)
    for b, r in zip(beam[ok], np.hypot(lx, ly)[ok], strict=True):
        ranges[b] = min(ranges[b], r)
    return LaserScan(stamp, a_min, inc, 0.05, 30.0, ranges)


def wall_x(x: float, half: float = 2.0) -> np.ndarray:
    """A wall across the robot's path at base_link x, points every 5 mm."""
    y = np.arange(-half, half, 0.005)
    return np.column_stack((np.full_like(y, x), y))


def post(x: float, y: float, r: float = 0.01) -> np.ndarray:
    a = np.linspace(0, 2 * math.pi, 12, endpoint=False)
    return np.column_stack((x + r * np.cos(a), y + r * np.sin(a)))


@pytest.fixture(scope="module")
def config() -> CollisionMonitorConfig:
    return load_safety_config(DEFAULT_SAFETY_YAML).monitor


def monitor_with(
    config: CollisionMonitorConfig, points: np.ndarray, now: float = 0.0
) -> CollisionMonitor:
    m = CollisionMonitor(config, MOUNT)
    m.on_scan(scan_of(points, now), now)
    return m


def test_free_space_passes_the_command_unchanged(config: CollisionMonitorConfig) -> None:
    m = monitor_with(config, wall_x(5.0))
    r = m.update(0.6, 0.3, 0.0)
    assert (r.linear, r.angular, r.zone) == (0.6, 0.3, "none")
    assert r.distance == pytest.approx(4.7, abs=0.01) or math.isinf(r.distance)


def test_stop_zone_blocks_approach_but_lets_the_robot_back_away(
    config: CollisionMonitorConfig,
) -> None:
    m = monitor_with(config, wall_x(0.32))  # 2 cm ahead of the bumper: inside the stop zone
    forward = m.update(0.3, 0.0, 0.0)
    assert (forward.linear, forward.angular, forward.zone) == (0.0, 0.0, "stop")
    assert forward.distance == pytest.approx(0.02, abs=0.005)
    back = m.update(-0.2, 0.0, 0.0)
    assert back.linear == pytest.approx(-0.2 * 0.6) and back.zone == "stop"  # and slowed
    turn_into = m.update(0.0, 0.8, 0.0)  # a turn swings the front corners into the wall
    assert turn_into.angular == 0.0


def test_slowdown_zone_scales_both_velocities(config: CollisionMonitorConfig) -> None:
    side = np.column_stack((np.arange(-0.3, 0.6, 0.01), np.full(90, 0.40)))  # beside, not ahead
    m = monitor_with(config, side)
    r = m.update(0.5, 0.0, 0.0)
    assert r.zone == "slowdown"
    assert r.linear == pytest.approx(0.5 * 0.6)


def test_approach_keeps_the_time_to_contact_along_a_straight_line(
    config: CollisionMonitorConfig,
) -> None:
    m = monitor_with(config, wall_x(2.0))
    slow = m.update(1.0, 0.0, 0.0)  # 1.68 m free at 1 m/s: 1.68 s > 1.2 s
    assert slow.linear == 1.0 and slow.zone == "none"
    fast = m.update(2.0, 0.0, 0.0)
    free = 2.0 - 0.32  # approach polygon's front at 0.32 m
    assert fast.zone == "approach"
    # v = free / T within one simulation step (0.05 s at 2 m/s = 0.1 m)
    assert free / 1.2 - 0.1 <= fast.linear <= free / 1.2 + 1e-9
    assert fast.time_to_contact == pytest.approx(free / 2.0, abs=0.05)


def test_approach_follows_the_commanded_arc(config: CollisionMonitorConfig) -> None:
    obstacle = post(1.2, 0.0, 0.05)  # a bollard dead ahead
    m = monitor_with(config, obstacle)
    straight = m.update(1.0, 0.0, 0.0)
    assert straight.zone == "approach" and straight.linear < 0.8
    curving = m.update(1.0, 1.2, 0.0)  # radius 0.83 m: swings clear of it
    assert curving.zone == "none" and curving.linear == 1.0


def test_approach_scales_a_turn_on_the_spot_only_towards_the_obstacle(
    config: CollisionMonitorConfig,
) -> None:
    # A post at 0.39 m, 60 degrees left: outside the footprint, but the front-left corner
    # (radius 0.41 m) reaches it after ~11 degrees of a left turn; a right turn needs ~71 degrees.
    p = (0.39 * math.cos(math.radians(60)), 0.39 * math.sin(math.radians(60)))
    approach_only = CollisionMonitorConfig(
        tuple(z for z in config.zones if z.action_type == "approach")
    )
    m = monitor_with(approach_only, post(*p, 0.003))
    left = m.update(0.0, 1.0, 0.0)
    assert left.zone == "approach"
    assert 0.0 <= left.angular < 0.3
    right = m.update(0.0, -1.0, 0.0)
    assert right.angular == -1.0 and right.zone == "none"


def test_hysteresis_keeps_a_zone_until_the_points_are_clearly_out(
    config: CollisionMonitorConfig,
) -> None:
    m = CollisionMonitor(config, MOUNT)

    def side(y: float, now: float) -> str:
        pts = np.column_stack((np.arange(-0.3, 0.3, 0.01), np.full(60, y)))
        m.on_scan(scan_of(pts, now), now)
        return m.update(0.2, 0.0, now).zone

    assert config.hysteresis == 0.02
    assert side(0.43, 0.0) == "none"  # 1 cm outside the slowdown zone (0.42)
    assert side(0.41, 0.1) == "slowdown"
    assert side(0.43, 0.2) == "slowdown"  # within the 2 cm hysteresis: still slowed
    assert side(0.435, 0.3) == "slowdown"
    assert side(0.45, 0.4) == "none"  # 3 cm out: released
    assert side(0.43, 0.5) == "none"  # and entering needs the zone itself again


def test_no_scan_or_a_stale_scan_stops_the_robot(config: CollisionMonitorConfig) -> None:
    m = CollisionMonitor(config, MOUNT)
    r = m.update(0.4, 0.0, 0.0)
    assert (r.linear, r.angular, r.zone) == (0.0, 0.0, "no_data")
    m.on_scan(scan_of(wall_x(5.0), 1.0), 1.0)
    assert m.update(0.4, 0.0, 1.2).linear == 0.4
    assert m.update(0.4, 0.0, 1.0 + config.source_timeout + 0.01).zone == "no_data"


def test_reversing_is_capped_because_nothing_behind_is_seen(config: CollisionMonitorConfig) -> None:
    m = monitor_with(config, wall_x(5.0))
    r = m.update(-0.6, 0.4, 0.0)
    assert r.linear == pytest.approx(-0.15) and r.angular == pytest.approx(0.1)  # same arc
    assert (r.zone, r.zone_name) == ("limit", "blind reverse")
    assert m.update(-0.1, 0.0, 0.0).linear == -0.1


def test_min_points_ignores_a_single_stray_return(config: CollisionMonitorConfig) -> None:
    m = monitor_with(config, np.array([[0.33, 0.0], [5.0, 0.0]]))  # one speck in the stop zone
    assert m.update(0.3, 0.0, 0.0).zone != "stop"


def test_configuration_is_nav2_shaped_and_bounds_checked(tmp_path: Path) -> None:
    good = {
        "polygons": ["Stop"],
        "Stop": {"type": "polygon", "points": "[[0.4, 0.3], [-0.4, 0.3], [-0.4, -0.3], [0.4, -0.3]]",
                 "action_type": "stop", "min_points": 4},
    }  # fmt: skip
    cfg = CollisionMonitorConfig.from_mapping({"ros__parameters": good})
    assert cfg.zones[0].points[0] == (0.4, 0.3) and cfg.zones[0].min_points == 4
    circle = ZoneConfig.from_mapping(
        "C", {"type": "circle", "radius": 0.5, "action_type": "slowdown"}
    )
    assert len(circle.points) == 24
    bad_cases = [
        ({**good, "Stop": {**good["Stop"], "action_type": "brake"}}, "action_type"),
        ({**good, "Stop": {**good["Stop"], "min_points": 0}}, "min_points"),
        ({**good, "Stop": {**good["Stop"], "slowdown_ratio": 1.5}}, "slowdown_ratio"),
        ({**good, "Stop": {**good["Stop"], "time_before_collision": -1}}, "time_before_collision"),
        ({**good, "Stop": {**good["Stop"], "points": [[0, 0], [1, 1]]}}, "points"),
        ({**good, "Stop": {**good["Stop"], "colour": "red"}}, "unknown"),
        ({**good, "polygons": ["Stop", "Missing"]}, "Missing"),
        ({**good, "hysteresis": 2.0}, "hysteresis"),
    ]
    for data, word in bad_cases:
        with pytest.raises(SafetyConfigError, match=word):
            CollisionMonitorConfig.from_mapping(data, "test.yaml")
    path = tmp_path / "bad.yaml"
    path.write_text("collision_monitor: {polygons: []}\n")
    with pytest.raises(SafetyConfigError, match=r"bad\.yaml"):
        load_safety_config(path)


def test_a_command_filtered_again_on_the_same_scan_gives_the_same_result(
    config: CollisionMonitorConfig,
) -> None:
    """The time to contact is kept per scan, zone and command (the stack filters each command
    twice a scan period): every result equals that of a monitor asked once, signed zeros and
    a new scan included."""
    rng = np.random.default_rng(5)
    kept = CollisionMonitor(config, MOUNT)
    commands = [(0.5, 0.0), (0.5, -0.0), (-0.0, 0.8), (0.0, 0.8), (0.4, 0.5), (0.4, -0.5)]
    approached = set()
    for k in range(12):
        points = np.vstack([post(float(x), float(y)) for x, y in rng.uniform(-0.9, 0.9, (6, 2))])
        points = points[np.hypot(points[:, 0], points[:, 1]) > 0.55]  # not inside the robot
        points = np.vstack([points, wall_x(float(rng.uniform(0.45, 0.8)))])
        now = 0.1 * k
        kept.on_scan(scan_of(points, now), now)
        for v, w in [*commands, *commands[::-1]]:  # each command twice on this scan
            fresh = CollisionMonitor(config, MOUNT)
            fresh.on_scan(scan_of(points, now), now)
            got, want = kept.update(v, w, now), fresh.update(v, w, now)
            assert got == want
            if math.isfinite(got.time_to_contact):
                approached.add(round(got.time_to_contact, 3))
            assert [math.copysign(1.0, a) for a in (got.linear, got.angular)] == [
                math.copysign(1.0, a) for a in (want.linear, want.angular)
            ]
    assert len(approached) > 5  # the approach zone acted, at many different times
