"""Localiser: tracking with the odometry prior, loss detection, map updates without people."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.localisation import (
    Localiser,
    LocaliserConfig,
    LocaliserState,
)
from robot_daemon.localisation.localiser import LocaliserConfigError

RATE = 40.0  # [Hz] UTM-30LX


def test_unset_until_an_initial_pose(world) -> None:
    loc = Localiser(world.grid)
    est = loc.on_scan(world.scan(Pose2D(2, 2, 0)), 0.0)
    assert est.state is LocaliserState.UNSET and est.pose is None
    loc.set_initial_pose(Pose2D(2, 2, 0), 0.1)
    est = loc.on_scan(world.scan(Pose2D(2, 2, 0)), 0.1)
    assert est.state is LocaliserState.OK
    assert est.pose is not None and est.pose.distance_to(Pose2D(2, 2, 0)) < 0.01


def test_tracks_a_drive_with_biased_odometry(world) -> None:
    """3 % odometry scale error and 2 % yaw error; the matcher keeps the pose within 1.5 cm."""
    truth = [Pose2D(6.5 + 0.02 * k, 1.5 + 0.01 * k, 0.4 + 0.004 * k) for k in range(120)]
    odo = world.odometry(scale=1.03, yaw_scale=1.02)
    loc = Localiser(world.grid)
    loc.on_odometry(odo.pose, 0.0)
    loc.set_initial_pose(truth[0], 0.0)
    for k in range(1, len(truth)):
        now = k / RATE
        loc.on_odometry(odo.step(truth[k - 1], truth[k]), now)
        est = loc.on_scan(world.scan(truth[k], now), now)
        assert est.state is LocaliserState.OK
        assert est.pose is not None
        assert est.pose.distance_to(truth[k]) < 0.015
        assert abs(angle_diff(est.pose.yaw, truth[k].yaw)) < math.radians(0.5)
        assert est.confidence > 0.9 and est.score > 0.8


def test_initial_pose_0p3m_off_is_corrected(world) -> None:
    truth = Pose2D(12.0, 4.0, -1.2)
    loc = Localiser(world.grid)
    loc.set_initial_pose(Pose2D(12.2, 3.8, -1.05), 0.0)
    est = loc.on_scan(world.scan(truth), 0.0)
    assert est.pose is not None and est.pose.distance_to(truth) < 0.02
    assert est.state is LocaliserState.OK


def test_teleport_is_reported_lost_within_2s_and_recovers(world) -> None:
    """Kidnapped robot: scans from another room while odometry says nothing moved."""
    here, there = Pose2D(6.5, 1.5, 0.4), Pose2D(16.0, 10.0, 2.0)
    loc = Localiser(world.grid)
    loc.on_odometry(Pose2D(0, 0, 0), 0.0)
    loc.set_initial_pose(here, 0.0)
    now = 0.0
    for _ in range(20):
        now += 1 / RATE
        assert loc.on_scan(world.scan(here, now), now).state is LocaliserState.OK
    kidnapped_at = now
    scan_there = world.scan(there, now)
    lost_at = None
    while now < kidnapped_at + 2.0:
        now += 1 / RATE
        est = loc.on_scan(scan_there, now)
        if est.state is LocaliserState.LOST:
            lost_at = now
            break
    assert lost_at is not None, "teleport not detected within 2 s"
    assert lost_at - kidnapped_at <= 2.0
    # While lost: dead reckoning on odometry, still reported lost.
    pose_when_lost = loc.pose
    assert pose_when_lost is not None
    loc.on_odometry(Pose2D(0.5, 0.0, 0.0), now + 0.1)
    est = loc.on_scan(scan_there, now + 0.1)
    assert est.state is LocaliserState.LOST
    assert est.pose is not None
    assert est.pose.distance_to(pose_when_lost.compose(Pose2D(0.5, 0, 0))) < 1e-9
    # A new initial pose (from the tablet) recovers.
    loc.set_initial_pose(Pose2D(16.1, 10.1, 2.05), now + 0.2)
    for k in range(5):
        t = now + 0.2 + k / RATE
        est = loc.on_scan(world.scan(there, t), t)
        assert est.state is LocaliserState.OK
    assert est.pose is not None and est.pose.distance_to(there) < 0.02


def test_single_implausible_scan_is_rejected_without_losing(world) -> None:
    """One scan from elsewhere: rejected and reported degraded (not ok, not lost); ok again
    after ``ok_after_s`` of good scans."""
    here = Pose2D(6.5, 1.5, 0.4)
    loc = Localiser(world.grid)
    loc.set_initial_pose(here, 0.0)
    loc.on_scan(world.scan(here, 0.0), 0.0)
    est = loc.on_scan(world.scan(Pose2D(16.0, 10.0, 2.0), 0.025), 0.025)
    assert est.pose is not None and est.pose.distance_to(here) < 0.02
    assert est.state is LocaliserState.DEGRADED and est.reason
    now = 0.05
    est = loc.on_scan(world.scan(here, now), now)
    assert est.state is LocaliserState.DEGRADED  # not yet ok_after_s of good scans
    while now < 0.05 + loc.config.ok_after_s + 0.01:
        now += 0.025
        est = loc.on_scan(world.scan(here, now), now)
    assert est.state is LocaliserState.OK and est.reason == ""
    assert est.pose is not None and est.pose.distance_to(here) < 0.01


def _patrol(t: float) -> Pose2D:
    """Robot drives back and forth along x = 6.5 .. 8 at y = 1.2, facing +x (period 10 s)."""
    return Pose2D(6.5 + 0.75 * (1.0 - math.cos(2 * math.pi * t / 10.0)), 1.2, 0.0)


def _run_patrol(
    world, duration: float, extra_at, rate: float = 10.0
) -> tuple[Localiser, float, int]:
    loc = Localiser(world.grid)
    odo = world.odometry()
    loc.on_odometry(odo.pose, 0.0)
    loc.set_initial_pose(_patrol(0.0), 0.0)
    worst = 0.0
    active = 0  # most cells with a live unexplained-hit streak at once
    n = int(duration * rate)
    for k in range(1, n + 1):
        t = k / rate
        loc.on_odometry(odo.step(_patrol(t - 1 / rate), _patrol(t)), t)
        est = loc.on_scan(world.scan(_patrol(t), t, extra_at(t)), t)
        assert est.state is LocaliserState.OK
        assert est.pose is not None
        worst = max(worst, est.pose.distance_to(_patrol(t)))
        active = max(active, loc.dynamic.active_cells(t))
    return loc, worst, active


def _people(t: float) -> list[np.ndarray]:
    """Three people crossing the robot's view along y at 1 m/s, again and again."""
    out = []
    for i, x in enumerate((8.8, 9.6, 11.0)):
        phase = (t + 2.3 * i) % 8.0  # each walks 0.3 -> 7.3 m then reappears
        out.append(np.array([[x - 0.2, 0.3 + phase - 0.2, x + 0.2, 0.3 + phase + 0.2]]))
    return out


def test_people_walking_by_are_not_burnt_into_the_map(world) -> None:
    loc, worst, active = _run_patrol(world, 30.0, _people)
    assert worst < 0.03
    assert active > 10  # the people were seen as unexplained hits...
    assert not loc.dynamic.promoted.any()  # ...but never became static
    assert np.array_equal(loc.updated_grid().cells, world.grid.cells)


def test_person_standing_briefly_is_not_burnt_in(world) -> None:
    def person(t: float) -> list[np.ndarray]:
        return [world.square(9.2, 1.5, 0.2)] if 5.0 <= t < 15.0 else []

    loc, _, active = _run_patrol(world, 30.0, person)
    assert active > 5
    assert not loc.dynamic.promoted.any()


def test_new_box_standing_for_long_becomes_static(world) -> None:
    box = world.square(9.2, 1.2, 0.25)
    loc, worst, _ = _run_patrol(world, 30.0, lambda t: [box] if t >= 2.0 else [])
    assert worst < 0.03
    promoted = loc.dynamic.promoted
    assert promoted.sum() >= 5
    rows, cols = np.nonzero(promoted)
    xs, ys = world.grid.cell_to_world(rows, cols)
    # Promoted cells lie on the box's visible (west) face, x = 8.95, y in 0.95 .. 1.45.
    assert np.all(np.abs(xs - 8.95) <= 0.06)
    assert np.all((ys >= 0.9) & (ys <= 1.5))
    grid = loc.updated_grid()
    assert np.all(grid.cells[promoted] == OCCUPIED)
    # The matching map now scores the box face as obstacle.
    m, _, _ = loc.matcher.levels[0].interpolate(xs.copy(), ys.copy())
    assert np.all(m > 0.9)


def test_box_seen_only_from_a_parked_robot_is_not_promoted(world) -> None:
    """Hits on one spot for 30 s, but the robot never moved: no promotion."""
    loc = Localiser(world.grid)
    here = Pose2D(7.0, 1.2, 0.0)
    loc.set_initial_pose(here, 0.0)
    box = world.square(9.2, 1.2, 0.25)
    for k in range(1, 301):
        loc.on_scan(world.scan(here, k / 10.0, [box]), k / 10.0)
    assert not loc.dynamic.promoted.any()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"hit_tolerance_m": 0.0},
        {"lost_after_s": 0.0},
        {"lost_confidence": 1.5},
        {"max_range_m": float("nan")},
        {"max_jump_rad": 4.0},
    ],
)
def test_config_rejects_out_of_range(kwargs: dict[str, float]) -> None:
    with pytest.raises(LocaliserConfigError, match=next(iter(kwargs))):
        LocaliserConfig(**kwargs)  # type: ignore[arg-type]


def test_current_pose_follows_odometry_between_scans() -> None:
    """Between two scans the pose to act on moves with odometry; the matched pose does not."""
    cells = np.full((100, 100), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    loc = Localiser(OccupancyGrid(cells, 0.05, 0.0, 0.0))
    loc.on_odometry(Pose2D(10.0, 0.0, 0.0), 0.0)
    loc.set_initial_pose(Pose2D(2.0, 2.0, math.pi / 2), 0.0)
    loc.on_odometry(Pose2D(10.3, 0.0, 0.0), 0.1)  # 0.3 m forward in odom, no scan yet
    assert loc.pose == Pose2D(2.0, 2.0, math.pi / 2)
    current = loc.current_pose
    assert current is not None
    assert (current.x, current.y) == pytest.approx((2.0, 2.3))  # forward = +y when facing +y
