"""Localisation replayed on real laser logs (Radish / Freiburg CARMEN logs), for tests and benches.

A map is built with `grid_from_scans` from the first part of a log and its logged (GMapping-
corrected) poses. The scans of the later part that revisit the mapped area (logged pose within
1 m of a mapping pose) are localised in runs, each run starting from its first logged pose, with
odometry made from the logged pose increments with 5 % scale error, a yaw bias of 0.02 rad per
metre and Gaussian noise (1 cm, 0.005 rad per step). Errors are against the logged poses, which
are themselves SLAM estimates (a few centimetres), not ground truth.

Used by ``tests/robot_daemon/localisation/test_loc_realdata.py`` (assertions) and
``bench/bench_reallogs.py`` (figures), so both report the same method.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from interbot_core.carmen_log import LaserRecord, read_laser_records
from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.mapping import grid_from_scans
from robot_daemon.localisation.scan_matcher import ScanMatcherConfig

REVISIT_RADIUS_M = 1.0  # [m] a scan revisits the map when its pose is this close to a mapping pose


class LogReplayError(ValueError):
    """A log cannot be replayed as asked (the message names the log and what is missing)."""


def revisit_runs(records: list[LaserRecord], split: int, min_len: int) -> list[list[LaserRecord]]:
    """Maximal runs (>= ``min_len`` scans) after ``split`` whose poses revisit the mapped part."""
    mapped = np.array([[r.pose.x, r.pose.y] for r in records[:split]])
    runs: list[list[LaserRecord]] = []
    current: list[LaserRecord] = []
    for r in records[split:]:
        if np.min(np.hypot(mapped[:, 0] - r.pose.x, mapped[:, 1] - r.pose.y)) < REVISIT_RADIUS_M:
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
    """Map the first ``split_fraction`` of the log at ``path``, localise the revisits of the rest.

    Every ``map_stride``-th scan builds the 0.05 m map; every ``loc_stride``-th scan of a revisit
    run is localised. Returns ``runs``, ``scans``, ``rms_m``, ``median_m``, ``max_m``,
    ``rms_yaw_rad``, ``max_yaw_rad``, ``lost_scans`` and ``odometry_only_rms_m`` (dead reckoning
    alone, for comparison).
    """
    if not 0.0 < split_fraction < 1.0 or map_stride < 1 or loc_stride < 1:
        raise LogReplayError(
            f"{path}: need 0 < split_fraction < 1 and strides >= 1, got {split_fraction}, "
            f"{map_stride}, {loc_stride}"
        )
    records = read_laser_records(path)
    split = int(split_fraction * len(records))
    mapping = records[:split:map_stride]
    if not mapping:
        raise LogReplayError(f"{path}: no scans to build a map from ({len(records)} records)")
    grid = grid_from_scans([r.scan for r in mapping], [r.pose for r in mapping], 0.05)
    # A map of binned end points: a wall lies anywhere in its cell, on average mid-cell.
    config = LocaliserConfig(matcher=ScanMatcherConfig(surface="cell_centre"))
    rng = np.random.default_rng(seed)
    errors: list[float] = []
    yaw_errors: list[float] = []
    odom_errors: list[float] = []
    lost = 0
    runs = revisit_runs(records, split, 10 * loc_stride)
    for run in runs:
        run = run[::loc_stride]
        loc = Localiser(grid, config)
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
            if est.pose is None:  # cannot happen after set_initial_pose; keeps the types honest
                raise LogReplayError(f"{path}: the localiser has no pose at t={cur.timestamp}")
            lost += est.state is LocaliserState.LOST
            errors.append(est.pose.distance_to(cur.pose))
            yaw_errors.append(abs(math.remainder(est.pose.yaw - cur.pose.yaw, math.tau)))
    if not errors:
        raise LogReplayError(f"{path}: no revisit run of >= {10 * loc_stride} scans to localise")
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
