"""Localisation on real laser logs (Radish / Freiburg CARMEN logs in ../shared/data).

A map is built with `grid_from_scans` from the first part of a log and its logged (GMapping-
corrected) poses. The scans of the later part that revisit the mapped area (logged pose within
1 m of a mapping pose) are localised in runs, each run starting from its first logged pose, with
odometry made from the logged pose increments with 5 % scale error, a yaw bias of 0.02 rad per
metre and Gaussian noise (1 cm, 0.005 rad per step). Errors are against the logged poses, which
are themselves SLAM estimates (a few centimetres), not ground truth.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from interbot_core.carmen_log import LaserRecord, read_laser_records
from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserState, grid_from_scans
from robot_daemon.localisation.mapping import scan_points_in_map

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"

pytestmark = pytest.mark.realdata


def _log(name: str) -> Path:
    path = LOGS / f"{name}-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    return path


def _revisit_runs(records: list[LaserRecord], split: int, min_len: int) -> list[list[LaserRecord]]:
    mapped = np.array([[r.pose.x, r.pose.y] for r in records[:split]])
    runs: list[list[LaserRecord]] = []
    current: list[LaserRecord] = []
    for r in records[split:]:
        if np.min(np.hypot(mapped[:, 0] - r.pose.x, mapped[:, 1] - r.pose.y)) < 1.0:
            current.append(r)
            continue
        if len(current) >= min_len:
            runs.append(current)
        current = []
    if len(current) >= min_len:
        runs.append(current)
    return runs


def localise_revisits(
    path: Path, split_fraction: float, map_stride: int, loc_stride: int, seed: int = 0
) -> dict[str, float]:
    """Map the first part, localise the revisits of the rest; error statistics."""
    records = read_laser_records(path)
    split = int(split_fraction * len(records))
    mapping = records[:split:map_stride]
    grid = grid_from_scans([r.scan for r in mapping], [r.pose for r in mapping], 0.05)
    rng = np.random.default_rng(seed)
    errors: list[float] = []
    yaw_errors: list[float] = []
    odom_errors: list[float] = []  # dead reckoning alone, for comparison
    lost = 0
    runs = _revisit_runs(records, split, 10 * loc_stride)
    for run in runs:
        run = run[::loc_stride]
        loc = Localiser(grid)
        odom = Pose2D(0.0, 0.0, 0.0)
        loc.on_odometry(odom, run[0].timestamp)
        loc.set_initial_pose(run[0].pose, run[0].timestamp)
        loc.on_scan(run[0].scan, run[0].timestamp)
        for prev, cur in itertools.pairwise(run):
            inc = cur.pose.relative_to(prev.pose)
            dist = math.hypot(inc.x, inc.y)
            noisy = Pose2D(
                1.05 * inc.x + rng.normal(0.0, 0.01),
                1.05 * inc.y + rng.normal(0.0, 0.01),
                inc.yaw + 0.02 * dist + rng.normal(0.0, 0.005),
            )
            odom = odom.compose(noisy)
            odom_errors.append(run[0].pose.compose(odom).distance_to(cur.pose))
            loc.on_odometry(odom, cur.timestamp)
            est = loc.on_scan(cur.scan, cur.timestamp)
            assert est.pose is not None
            lost += est.state is LocaliserState.LOST
            errors.append(est.pose.distance_to(cur.pose))
            yaw_errors.append(abs(math.remainder(est.pose.yaw - cur.pose.yaw, math.tau)))
    err, yerr = np.array(errors), np.array(yaw_errors)
    return {
        "runs": float(len(runs)),
        "scans": float(err.size),
        "rms_m": float(np.sqrt(np.mean(err**2))),
        "median_m": float(np.median(err)),
        "max_m": float(err.max()),
        "rms_yaw_rad": float(np.sqrt(np.mean(yerr**2))),
        "max_yaw_rad": float(yerr.max()),
        "lost_scans": float(lost),
        "odometry_only_rms_m": float(np.sqrt(np.mean(np.square(odom_errors)))),
    }


def test_intel_lab_revisits(record_property) -> None:
    stats = localise_revisits(_log("intel"), 0.5, 2, 1)
    for key, value in stats.items():
        record_property(key, value)
    assert stats["scans"] >= 150
    assert stats["lost_scans"] == 0
    assert stats["median_m"] < 0.05
    assert stats["rms_m"] < 0.12
    assert stats["rms_yaw_rad"] < 0.02
    assert stats["rms_m"] < stats["odometry_only_rms_m"] / 3


def test_freiburg_079_revisits(record_property) -> None:
    stats = localise_revisits(_log("freiburg-079"), 0.5, 6, 4)
    for key, value in stats.items():
        record_property(key, value)
    assert stats["scans"] >= 150
    assert stats["lost_scans"] == 0
    assert stats["median_m"] < 0.05
    assert stats["rms_m"] < 0.08
    assert stats["rms_yaw_rad"] < 0.02
    assert stats["rms_m"] < stats["odometry_only_rms_m"] / 3


def _cross_consistency(records: list[LaserRecord], increment_of: dict[int, float]) -> float:
    """Fraction of end points of odd scans within 5 cm of the map built from even scans."""
    scans = [
        dataclasses.replace(r.scan, angle_increment=increment_of[r.scan.ranges.size])
        for r in records
    ]
    poses = [r.pose for r in records]
    grid = grid_from_scans(scans[::2], poses[::2], 0.05, min_hits=1)
    dist = ndimage.distance_transform_edt(~grid.occupied()) * grid.resolution
    near = []
    for scan, pose in zip(scans[1::2], poses[1::2], strict=True):
        pts = scan_points_in_map(scan, pose, 15.0)
        rows, cols = grid.world_to_cell(pts[:, 0], pts[:, 1])
        ok = grid.in_bounds(rows, cols)
        near.append(
            np.where(
                ok,
                dist[np.clip(rows, 0, grid.height - 1), np.clip(cols, 0, grid.width - 1)],
                np.inf,
            )
            <= 0.05
        )
    return float(np.mean(np.concatenate(near)))


def test_beam_convention_even_counts_use_pi_over_n() -> None:
    """180 beams: 1 degree steps from -90 degrees (to +89), not pi/179 (to +90).

    The convention CARMEN/GMapping used gives the sharper map: scans of one half of the log
    agree better with the map of the other half.
    """
    records = read_laser_records(_log("intel"))[::2]
    even = _cross_consistency(records, {180: math.pi / 180})
    odd = _cross_consistency(records, {180: math.pi / 179})
    assert even > odd
