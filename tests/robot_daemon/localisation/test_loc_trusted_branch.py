"""Robust to the odometry's draw (issue 12): the last trusted estimate's branch, and several
starts under a wide heading prior.

Two changes of `Localiser.on_scan`:

* While the estimate is not trusted (a bad scan, or a jump not yet re-confirmed), the last
  trusted estimate, carried forward by odometry alone, is a second hypothesis
  (`Localiser._match_trusted`): the scan is matched from it too, and where that fits clearly
  better (and passes its own gate) it is taken. The CSAIL revisit with odometry seeds 2 and 4-6
  was lost once per run: three scans of a fast spin in place fit the map 11 degrees off the
  logged poses, the filter followed two of them, and after the spin it could not come back.
* A match whose prediction's heading sigma exceeds ``starts_above_rad`` (a person's initial
  10 degrees) is matched from several starts, as the first one after a set pose
  (`Localiser._match_from_starts`): Gauss-Newton converges only within a few degrees. The
  Örebro whole log with seed 2 (5 m between scans, heading sigma 15 degrees) settled 0.8 m
  along a corridor from a heading 6 degrees off, and was lost.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserConfig
from robot_daemon.localisation.localiser import LocaliserState
from tests.robot_daemon.localisation.carmen_log import LaserRecord, read_laser_records
from tests.robot_daemon.localisation.log_replay import (
    localise_interleaved,
    log_config,
    map_of,
    replay_run,
    revisit_runs,
    summarise,
)
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"
TRUTH = Pose2D(2.0, 2.0, 0.3)  # the office's south-west corner: a wrong heading fits locally


def _office() -> tuple[Localiser, np.ndarray]:
    loc = Localiser(office_grid(), LocaliserConfig(map_update=False))
    points = loc._scan_points(utm_scan(OFFICE_BOXES, TRUTH, 0.0, np.random.default_rng(1)))
    return loc, points


def test_the_trusted_branch_wins_where_the_filter_sits_in_a_wrong_optimum() -> None:
    """The filter's match, from a heading 20 degrees off, stopped in a wrong optimum and was
    rejected; the trusted branch's prediction, near the truth, matches to it and is fused."""
    loc, points = _office()
    wrong = loc.matcher.match(points, Pose2D(TRUTH.x, TRUTH.y, TRUTH.yaw + 0.35), 0)
    assert abs(wrong.pose.yaw - TRUTH.yaw) > math.radians(5.0)  # a wrong optimum
    branch = (Pose2D(2.05, 1.97, 0.32), np.diag([0.05**2, 0.05**2, 0.03**2]))
    out = loc._match_trusted(points, branch, wrong, None, Pose2D(0.0, 0.0, 0.0))
    assert out is not None
    result, (pose, _) = out
    assert result.score > 1.05 * wrong.score
    assert pose.distance_to(TRUTH) < 0.02 and abs(pose.yaw - TRUTH.yaw) < math.radians(0.5)


def test_the_filter_keeps_its_match_when_the_branch_fits_no_better() -> None:
    """Both hypotheses find the same optimum: the filter's fused match stands (no switch, and
    so no jump), and a branch at the filter's match is not matched at all."""
    loc, points = _office()
    right = loc.matcher.match(points, TRUTH, 0)
    cov = np.diag([0.05**2, 0.05**2, 0.03**2])
    fused = loc._fuse(TRUTH, cov, right, Pose2D(0.0, 0.0, 0.0))
    assert fused is not None
    branch = (Pose2D(2.08, 1.95, 0.33), cov)  # distinct, but the same basin
    assert loc._match_trusted(points, branch, right, fused, Pose2D(0.0, 0.0, 0.0)) is None
    same = (right.pose, cov)
    assert loc._match_trusted(points, same, right, fused, Pose2D(0.0, 0.0, 0.0)) is None


def test_the_branch_is_kept_while_untrusted_and_no_wider_than_a_persons_pose() -> None:
    """After a bad scan the previous estimate (this scan's prediction) becomes the branch and
    is carried while the estimate stays untrusted; it ends once wider than a person's initial
    pose (0.3 m, 10 degrees), and when the estimate is trusted again."""
    loc, _ = _office()
    tight = (TRUTH, np.diag([0.05**2, 0.05**2, 0.03**2]))
    wide = (TRUTH, np.diag([0.35**2, 0.05**2, 0.03**2]))
    loc._was_trusted = True
    loc._keep_trusted_branch(LocaliserState.DEGRADED, True, None, tight)
    assert loc._trusted is tight  # the last trusted estimate, carried from now on
    loc._keep_trusted_branch(LocaliserState.DEGRADED, True, tight, wide)
    assert loc._trusted is tight  # still untrusted: the carried branch, not the prediction
    loc._keep_trusted_branch(LocaliserState.DEGRADED, True, wide, tight)
    assert loc._trusted is None  # no surer than a person's pose: ended
    loc._was_trusted = True
    loc._keep_trusted_branch(LocaliserState.OK, False, None, tight)
    assert loc._trusted is None and loc._was_trusted  # trusted: no branch


def test_after_bad_scans_the_branch_is_kept_until_the_estimate_is_ok_again() -> None:
    """A good scan after a bad one re-confirms nothing: the branch is carried while the
    estimate recovers (degraded, no bad scan, no jump) and ends once it is ok; a degraded
    estimate that was trusted (an uncertain corridor, no bad scan) stays trusted."""
    loc, _ = _office()
    tight = (TRUTH, np.diag([0.05**2, 0.05**2, 0.03**2]))
    loc._was_trusted = True
    loc._keep_trusted_branch(LocaliserState.DEGRADED, True, None, tight)  # a bad scan
    assert loc._trusted is tight
    loc._keep_trusted_branch(LocaliserState.DEGRADED, False, tight, tight)  # recovering
    assert loc._trusted is tight and not loc._was_trusted
    loc._keep_trusted_branch(LocaliserState.OK, False, tight, tight)  # re-confirmed
    assert loc._trusted is None and loc._was_trusted
    loc._keep_trusted_branch(LocaliserState.DEGRADED, False, None, tight)  # uncertain only
    assert loc._trusted is None and loc._was_trusted


def test_a_best_start_where_the_scan_fits_nowhere_is_not_taken() -> None:
    """`_wide_heading_match` keeps the prediction's own match when the best of the starts is
    a bad scan where it lands (hit fraction under ``lost_confidence``): end points that
    belong to no wall of the office fit somewhere by chance."""
    loc, _ = _office()
    rng = np.random.default_rng(4)
    angles = rng.uniform(-2.0, 2.0, 300)
    ranges = rng.uniform(0.5, 1.5, 300)  # clutter within 1.5 m of a laser in open floor
    points = np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles)))
    middle = Pose2D(10.0, 6.0, 0.0)
    own = loc.matcher.match(points, middle, 0)
    cov = np.diag([0.1**2, 0.1**2, 0.3**2])
    kept = loc._wide_heading_match(points, middle, cov, 0)
    assert (kept.pose, kept.score) == (own.pose, own.score)


@pytest.mark.parametrize("starts_above_rad", [0.17, math.pi])
def test_a_wide_heading_prior_is_matched_from_several_starts(starts_above_rad: float) -> None:
    """The odometry reports a 40 degree turn where the robot turned 25 (odom_alpha_rot 0.5:
    the prediction's heading sigma is 20 degrees): from several starts the scan is matched at
    the truth; from the prediction alone (``starts_above_rad`` = pi, the old behaviour)
    Gauss-Newton stops 5 degrees off, beams through walls."""
    config = LocaliserConfig(
        map_update=False, odom_alpha_rot=0.5, starts_above_rad=starts_above_rad
    )
    loc = Localiser(office_grid(), config)
    rng = np.random.default_rng(1)
    loc.on_odometry(Pose2D(0.0, 0.0, 0.0), 0.0)
    loc.set_initial_pose(TRUTH, 0.0, np.diag([0.01**2, 0.01**2, 0.01**2]))
    loc.on_scan(utm_scan(OFFICE_BOXES, TRUTH, 0.0, rng), 0.0)
    turned = Pose2D(TRUTH.x, TRUTH.y, TRUTH.yaw + math.radians(25.0))
    loc.on_odometry(Pose2D(0.0, 0.0, math.radians(40.0)), 1.0)
    est = loc.on_scan(utm_scan(OFFICE_BOXES, turned, 1.0, rng), 1.0)
    assert est.pose is not None
    yaw_error = abs(math.remainder(est.pose.yaw - turned.yaw, math.tau))
    if starts_above_rad < 1.0:
        assert yaw_error < math.radians(0.5) and est.pose.distance_to(turned) < 0.02
        assert est.state is LocaliserState.DEGRADED and est.reason.startswith("pose jumped")
    else:
        assert yaw_error > math.radians(3.0)  # the old behaviour: the test can fail


def _log(name: str) -> list[LaserRecord]:
    path = LOGS / f"{name}-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    return read_laser_records(path)


@pytest.mark.realdata
def test_csail_revisit_is_tracked_through_the_spin_for_every_odometry_draw() -> None:
    """CSAIL's revisit (the bench's method and strides) with the odometry seeds that lost it
    once (2, 4, 5, 6; session 8: RMS 23-37 cm; 8 with the heading-drift state, session 15:
    21 cm): never lost, RMS within 4 cm, 0 silent."""
    records = _log("csail")
    split = len(records) // 2
    runs = revisit_runs(records, split, 10)
    grid = map_of(records[:split])
    prototype = Localiser(grid, log_config())
    for seed in (2, 4, 5, 6, 8):
        rng = np.random.default_rng(seed)
        outcomes = []
        for run in runs:
            outcomes += replay_run(grid, run, rng, check_reference=False, prototype=prototype)
        stats = summarise(outcomes)
        assert stats["lost_scans"] == 0, seed
        assert stats["silent_failures"] == 0, seed
        assert stats["rms_m"] < 0.04, (seed, stats["rms_m"])


@pytest.mark.realdata
def test_orebro_whole_log_seed_2_is_not_lost() -> None:
    """Örebro's whole log (stride 2, the bench's) with odometry seed 2 (session 8: 21.4 cm,
    lost once after a 0.8 m slip along a corridor): not lost, RMS within 4 cm, 0 silent."""
    records = _log("orebro")
    stats = localise_interleaved(LOGS / "orebro-corrected.log.gz", 2, 2, records=records)
    assert stats["lost_scans"] == 0
    assert stats["silent_failures"] == 0
    assert stats["rms_m"] < 0.04
