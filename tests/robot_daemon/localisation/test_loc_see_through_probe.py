"""The see-through test's probe (`Localiser._probe_clean`, issue 12 speed): after a few clean
scans only every ``impossible_probe_stride``-th traced beam is traced; any impossible one among
them brings back the full test. Its one approximation (runs shorter than the stride between
the probed beams go unseen) is shown below too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from robot_daemon.localisation import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.scan_matcher import subsample_points
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan

TRUTH = Pose2D(6.0, 3.0, math.radians(100.0))  # the desk at (3-3.8, 5-5.5) about 3 m ahead-left
DESK = np.array([3.0, 5.0, 3.8, 5.5])
WITHOUT_DESK = np.array([box for box in OFFICE_BOXES if not np.array_equal(box, DESK)])


class CountingLocaliser(Localiser):
    """Counts the rays the see-through test traces on each scan."""

    rays = 0

    def _trace_rays(self, points, pose, max_beams):  # type: ignore[no-untyped-def]
        self.rays += subsample_points(points, max_beams).shape[0]
        return super()._trace_rays(points, pose, max_beams)


def _track(stride: int, scans: list[LaserScan]) -> tuple[list[tuple], list[int]]:
    """The estimates (pose, state, impossible, covariance, whether the scan had beams through
    the map's walls before the see-through allowance) and the rays traced per scan of a
    localiser at the truth fed ``scans`` (the robot standing still)."""
    loc = CountingLocaliser(office_grid(), LocaliserConfig(impossible_probe_stride=stride))
    loc.on_odometry(Pose2D(0.0, 0.0, 0.0), 0.0)
    loc.set_initial_pose(TRUTH, 0.0, np.diag([0.01**2, 0.01**2, 0.005**2]))
    estimates, rays = [], []
    for k, scan in enumerate(scans):
        loc.rays = 0
        loc.on_odometry(Pose2D(0.0, 0.0, 0.0), 0.1 * (k + 1))
        est = loc.on_scan(scan, 0.1 * (k + 1))
        estimates.append(
            (est.pose, est.state, est.impossible, est.covariance.tolist(), loc._saw_through)
        )
        rays.append(loc.rays)
    return estimates, rays


def test_clean_scans_are_probed_and_a_probe_that_finds_a_beam_through_a_wall_runs_the_full_test() -> (
    None
):
    """Six clean scans, then two whose beams pass where the map has a desk (moved away), then
    clean again: every estimate equals the full test's; after three clean scans in a row a
    scan traces a quarter of the beams, the desk's scans are traced in full (their
    beams through the desk seen; the see-through allowance then lets them pass: they land on
    the wall behind), and the probe resumes only after three clean scans again."""
    rng = np.random.default_rng(3)
    scans = [utm_scan(OFFICE_BOXES, TRUTH, 0.0, rng) for _ in range(6)]
    scans += [utm_scan(WITHOUT_DESK, TRUTH, 0.0, rng) for _ in range(2)]
    scans += [utm_scan(OFFICE_BOXES, TRUTH, 0.0, rng) for _ in range(5)]
    probed, probed_rays = _track(4, scans)
    full, full_rays = _track(1, scans)
    assert probed == full
    saw = [est[4] for est in probed]
    assert saw == [k in (6, 7) for k in range(len(scans))]  # the desk's beams, seen
    loc = Localiser(office_grid())
    n = subsample_points(loc._scan_points(scans[0]), loc.config.impossible_max_beams).shape[0]
    quarter = -(-n // 4)  # every fourth traced beam
    assert probed_rays[3:6] == [quarter] * 3  # probed once three scans were clean
    assert min(full_rays[3:6]) == n  # the full test: every beam
    assert probed_rays[6] == full_rays[6] + quarter  # the probe, then the full test
    assert probed_rays[7:11] == full_rays[7:11]  # full until three clean scans again
    assert probed_rays[11:] == [quarter] * 2


def test_no_probe_while_not_ok_or_switched_off() -> None:
    """The probe needs the state ok (not degraded or lost) and a stride above 1."""
    loc = Localiser(office_grid())
    loc.set_initial_pose(TRUTH, 0.0)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, TRUTH, 0.0, np.random.default_rng(1)))
    loc._clean_scans = 10
    assert loc._probe_clean(points, TRUTH)
    loc._state = LocaliserState.DEGRADED
    assert not loc._probe_clean(points, TRUTH)
    loc._state = LocaliserState.OK
    loc._clean_scans = 2
    assert not loc._probe_clean(points, TRUTH)
    off = Localiser(office_grid(), LocaliserConfig(impossible_probe_stride=1))
    off.set_initial_pose(TRUTH, 0.0)
    off._clean_scans = 10
    assert not off._probe_clean(points, TRUTH)


def test_a_run_shorter_than_the_stride_between_probed_beams_goes_unseen() -> None:
    """The approximation, shown: two neighbouring traced beams through a wall, both between
    probed ones, make the full test's fraction 1 % and the probe's 0; a scan is bad only past
    ``lost_impossible`` (5 %), which needs ten such beams, and a run of four or more always
    holds a probed one."""
    loc = Localiser(office_grid())
    loc.set_initial_pose(TRUTH, 0.0)
    loc._clean_scans = 10
    points = loc._scan_points(utm_scan(OFFICE_BOXES, TRUTH, 0.0, np.random.default_rng(2)))
    traced = subsample_points(points, loc.config.impossible_max_beams)
    stride = points.shape[0] // traced.shape[0] + (points.shape[0] % traced.shape[0] > 0)
    ranges = np.hypot(traced[:, 0], traced[:, 1])
    # Four traced beams in a row hitting a wall 1-6 m away, the first one probed (index 0 mod 4).
    first = next(
        k
        for k in range(0, traced.shape[0] - 4, 4)
        if np.all((ranges[k : k + 4] > 1.0) & (ranges[k : k + 4] < 6.0))
    )
    for run, expected_probe in (((first + 1, first + 2), True), ((first, first + 1), False)):
        longer = points.copy()
        for k in run:  # 1.5 m farther: through the wall
            longer[k * stride] *= (ranges[k] + 1.5) / ranges[k]
        assert loc.impossible_fraction(longer, TRUTH) == pytest.approx(2 / traced.shape[0])
        assert loc._probe_clean(longer, TRUTH) is expected_probe
