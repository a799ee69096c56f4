"""`log_replay.reference_consistency`: the logged poses against their own scans (issue 12).

A synthetic log with known poses: a SICK-like laser (180 degrees, 361 beams, 1 cm range noise, as
in the Freiburg 079 log) driven through the synthetic office a scan every 0.1 m, its boxes off
the 5 cm lattice. With the exact poses logged the check finds them; with poses that jitter as a
SLAM estimate's do, it measures the jitter, not the localiser's or the map's error.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from tests.robot_daemon.localisation.carmen_log import LaserRecord
from tests.robot_daemon.localisation.log_replay import (
    point_to_line_icp,
    reference_consistency,
    reference_pass_consistency,
    scan_points_in_map,
)
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, cast_ranges

BEAMS = 361
WAYPOINTS = [(1.5, 7.0), (7.6, 7.0), (7.6, 10.0), (2.0, 10.0)]


def _path(step: float = 0.1) -> list[Pose2D]:
    poses: list[Pose2D] = []
    for (x0, y0), (x1, y1) in itertools.pairwise(WAYPOINTS):
        yaw = math.atan2(y1 - y0, x1 - x0)
        n = round(math.hypot(x1 - x0, y1 - y0) / step)
        poses += [Pose2D(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, yaw) for k in range(n)]
    return poses


def _log(
    jitter_m: float, jitter_rad: float, seed: int = 0, noise_seed: int | None = None
) -> list[LaserRecord]:
    """Scans cast at the true poses; the poses logged with Gaussian jitter per axis. ``seed``
    draws the world (boxes off the lattice), ``noise_seed`` (default: the same) the noise."""
    rng = np.random.default_rng(seed)
    boxes = OFFICE_BOXES + rng.uniform(-0.025, 0.025, OFFICE_BOXES.shape)
    if noise_seed is not None:
        rng = np.random.default_rng(noise_seed)
    increment = math.pi / (BEAMS - 1)
    angles = -math.pi / 2 + increment * np.arange(BEAMS)
    out = []
    for i, truth in enumerate(_path()):
        r = cast_ranges(boxes, truth, angles, 30.0) + rng.normal(0.0, 0.01, BEAMS)
        r = np.where(np.isfinite(r), r, 81.9)
        scan = LaserScan(0.1 * i, -math.pi / 2, increment, 0.01, 80.0, r.astype(np.float32))
        logged = Pose2D(
            truth.x + rng.normal(0.0, jitter_m),
            truth.y + rng.normal(0.0, jitter_m),
            truth.yaw + rng.normal(0.0, jitter_rad),
        )
        out.append(LaserRecord(scan, logged, logged, 0.1 * i, i))
    return out


def test_exact_poses_are_consistent_with_their_scans() -> None:
    stats = reference_consistency(_log(0.0, 0.0))
    assert stats["consistency_scans"] > 100
    assert stats["consistency_rms_m"] < 0.008
    assert stats["consistency_rms_rad"] < math.radians(0.15)


def test_jittered_poses_measure_their_jitter() -> None:
    """Logged poses jittered by 1.5 cm per axis and 0.4 degrees: a scan against the two before
    it differs by the jitter of three poses, about sqrt(1.5) x 2.1 cm = 2.6 cm RMS and
    0.5 degrees (measured 2.7 cm and 0.43 degrees on the whole office)."""
    stats = reference_consistency(_log(0.015, math.radians(0.4)))
    assert 0.018 < stats["consistency_rms_m"] < 0.04
    assert math.radians(0.25) < stats["consistency_rms_rad"] < math.radians(0.7)


def test_a_second_pass_with_shifted_poses_measures_the_shift() -> None:
    """The same path driven twice; the second pass logged 3 cm off along x (a SLAM estimate's
    loop closure left a step): the second pass's scans against the first pass's measure it,
    with exact first-pass poses; with exact poses throughout, nothing."""
    first = _log(0.0, 0.0, seed=0)
    second = _log(0.0, 0.0, seed=0, noise_seed=1)  # the same world, other range noise
    exact = reference_pass_consistency(first + second, len(first))
    assert exact["consistency_scans"] > 100
    assert exact["consistency_rms_m"] < 0.008
    shifted = [
        LaserRecord(
            r.scan, Pose2D(r.pose.x + 0.03, r.pose.y, r.pose.yaw), r.odom_pose, r.timestamp, 0
        )
        for r in second
    ]
    stats = reference_pass_consistency(first + shifted, len(first))
    assert stats["consistency_rms_m"] == pytest.approx(0.03, abs=0.008)
    assert stats["consistency_rms_rad"] < math.radians(0.15)


def test_scans_far_from_their_predecessors_are_not_checked() -> None:
    """A log with a scan every metre (most Radish logs) has nothing this check can use."""
    sparse = _log(0.0, 0.0)[::10]
    stats = reference_consistency(sparse)
    assert stats["consistency_scans"] == 0.0
    assert math.isnan(stats["consistency_rms_m"])


def test_icp_recovers_a_shifted_pose() -> None:
    """One scan matched to the two before it from a start 5 cm and 1 degree off."""
    log = _log(0.0, 0.0)
    before, cur = log[20:22], log[22]
    reference = np.vstack([scan_points_in_map(r.scan, r.pose, 10.0) for r in before])
    start = Pose2D(cur.pose.x + 0.04, cur.pose.y - 0.03, cur.pose.yaw + math.radians(1.0))
    fit = point_to_line_icp(reference, cur.scan.points(10.0), start)
    assert fit is not None
    assert fit.distance_to(cur.pose) < 0.005
    assert abs(fit.yaw - cur.pose.yaw) == pytest.approx(0.0, abs=math.radians(0.1))
