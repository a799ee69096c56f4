"""A jump is re-confirmed before the pose is reported ok again (issue 12: never silently wrong).

A *jump* is a scan whose fused match moves the pose more than ``confirm_jump_m`` (0.15 m) or
``confirm_jump_rad`` (5 degrees) from the odometry prediction (`Localiser._update_state`). The
Kalman update's covariance does not depend on how far the match moved the pose, so the scan
after a look-alike match claimed 9 cm while 0.43 m off, and the next scans matched the same
look-alike again: the MIT Infinite Corridor revisit with odometry seed 2 was reported ok 0.43 m
off (scan 1326 of the log). Now such a scan is degraded, its spread is in the reported
covariance, and ok comes back only after ``ok_after_scans`` good scans after it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig, LocaliserState
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import map_of, replay_run, revisit_runs
from tests.robot_daemon.localisation.synthetic_office import rasterise, square, utm_scan

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"

# A corridor 60 m long and 2 m wide, featureless but for two pillars at x = 40 m; the laser
# sees 8 m (max_range_m), so along the corridor only the odometry holds the pose until the
# pillars come into view.
CORRIDOR = np.vstack(
    [
        np.array([[0.0, 0.0, 60.0, 0.1], [0.0, 2.0, 60.0, 2.1]]),
        np.array([[0.0, 0.0, 0.1, 2.1], [59.9, 0.0, 60.0, 2.1]]),
        square(40.0, 0.35, 0.25),
        square(40.0, 1.75, 0.25),
    ]
)


def _drive(config: LocaliserConfig) -> list[tuple[float, LocaliserState, float, str]]:
    """Drive the corridor from x = 28 m to the pillars at 40 m at 1 m per scan (one scan per
    second, as the real logs), then on at 5 cm per scan, odometry reading 4 % long. Per scan:
    the error along the corridor [m], the state, the reported sigma along it [m], the reason."""
    grid = rasterise(CORRIDOR, size=(60.0, 2.1))
    rng = np.random.default_rng(3)
    loc = Localiser(grid, config)
    truth = [Pose2D(28.0 + k, 1.05, 0.0) for k in range(13)]
    truth += [Pose2D(40.0 + 0.05 * k, 1.05, 0.0) for k in range(1, 9)]
    odom = Pose2D(0.0, 0.0, 0.0)
    loc.on_odometry(odom, 0.0)
    loc.set_initial_pose(truth[0], 0.0)
    loc.on_scan(utm_scan(CORRIDOR, truth[0], 0.0, rng), 0.0)
    out = []
    for k in range(1, len(truth)):
        odom = odom.compose(Pose2D(1.04 * (truth[k].x - truth[k - 1].x), 0.0, 0.0))
        loc.on_odometry(odom, float(k))
        est = loc.on_scan(utm_scan(CORRIDOR, truth[k], float(k), rng), float(k))
        assert est.pose is not None
        sigma = math.sqrt(float(est.covariance[0, 0]))
        out.append((est.pose.x - truth[k].x, est.state, sigma, est.reason))
    return out


def test_a_jump_is_degraded_until_good_scans_confirm_it() -> None:
    """The pillars fix the position the odometry let drift 0.4-0.5 m: the scan that moves the
    pose there is degraded and says why, its reported sigma holds the jump (not the few
    centimetres the match alone claims), the scans after it say the jump is being confirmed,
    still holding its spread, and ok comes back after ``ok_after_scans`` scans that do not
    jump; without the rule (``confirm_jump_m`` beyond any jump) those scans claimed the
    match's few centimetres before anything had confirmed it.

    The scan that first sees the pillars finds them only by the slide test's re-match, whose
    correction along the corridor is left to the odometry (`Localiser._retry_information`:
    two optima along it); the next scan's own match makes the jump."""
    config = LocaliserConfig(max_range_m=4.0)
    drive = _drive(config)
    fixed = [
        k for k in range(1, len(drive)) if abs(drive[k - 1][0]) > 0.3 > 0.05 > abs(drive[k][0])
    ]
    assert fixed, "the pillars did not correct the drifted pose in one scan"
    k = fixed[0]
    before, _, _, _ = drive[k - 1]
    after, state, sigma, reason = drive[k]
    assert state is LocaliserState.DEGRADED and reason
    assert sigma >= abs(before - after) / math.sqrt(2.0) - 0.05  # the jump's spread, reported
    n = config.ok_after_scans
    confirming = drive[k + 1 : k + n]
    assert [s for _, s, _, _ in confirming] == [LocaliserState.DEGRADED] * (n - 1)
    assert all(r.startswith("pose jumped") for _, _, _, r in confirming)
    assert all(sg >= abs(before - after) / math.sqrt(2.0) - 0.05 for _, _, sg, _ in confirming)
    assert drive[k + n][1] is LocaliserState.OK
    assert drive[k + n][2] < 0.1  # confirmed: the spread is gone from the covariance

    without = _drive(LocaliserConfig(max_range_m=4.0, confirm_jump_m=10.0, confirm_jump_rad=3.0))
    assert abs(without[k][0]) < 0.05  # the same correction
    assert all(sg < 0.1 for _, _, sg, _ in without[k + 1 : k + n])  # claimed, unconfirmed


def test_the_first_match_after_a_set_pose_is_not_a_jump() -> None:
    """A person's pose is up to 0.3 m and 10 degrees off: the first match is expected to move
    it that far (`_match_from_starts`), and the pose is ok at once, as before."""
    grid = rasterise(CORRIDOR, size=(60.0, 2.1))
    truth = Pose2D(40.5, 1.05, 0.0)  # beside the pillars: the scan fixes every direction
    loc = Localiser(grid, LocaliserConfig(max_range_m=4.0))
    loc.set_initial_pose(Pose2D(40.3, 1.2, 0.1), 0.0)
    est = loc.on_scan(utm_scan(CORRIDOR, truth, 0.0, np.random.default_rng(1)), 0.0)
    assert est.pose is not None and est.pose.distance_to(truth) < 0.03
    assert est.state is LocaliserState.OK and est.reason == ""


@pytest.mark.realdata
def test_infinite_corridor_revisit_seed_2_is_not_ok_after_a_look_alike_jump(
    record_property,
) -> None:
    """The MIT Infinite Corridor's revisit with odometry seed 2 (`log_replay.replay_run`, the
    bench's method), its first run up to the look-alike: scan 1324 matched 0.46 m from the
    prediction, a door recess like the right one; the pose, 0.1 m off before, was 0.48 m off
    after it, and the scans that followed matched the same look-alike. Before the jump rule
    scan 1326 was reported ok 0.43 m off (NEES 19): a silent failure."""
    path = LOGS / "infinite-corridor-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)
    split = len(records) // 2
    run = revisit_runs(records, split, 10)[0]
    assert run[0] is records[1233]  # the run the bench replays first: seed 2's draws start here
    outcomes = replay_run(
        map_of(records[:split]), run[:96], np.random.default_rng(2), check_reference=False
    )
    errors = [o.error_m for o in outcomes]
    record_property("max_m", max(errors))
    record_property("ok_max_m", max(o.error_m for o in outcomes if o.state is LocaliserState.OK))
    assert not [k for k, o in enumerate(outcomes) if o.silent]
