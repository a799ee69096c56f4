"""`log_replay.summarise`'s time figures: what the p99 holds (issue 12)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_daemon.localisation.localiser import LocaliserState
from tests.robot_daemon.localisation.log_replay import ScanOutcome, summarise


def _outcome(ms: float, after_set_pose: bool = False) -> ScanOutcome:
    return ScanOutcome(
        0.01, 0.001, LocaliserState.OK, 1.0, ms / 1e3, 0.1, 0.0, True, after_set_pose
    )


def test_tracking_p99_leaves_out_the_scans_after_a_set_pose() -> None:
    """Two slow first matches after re-set poses in 100 scans make the p99; the tracking p99
    is that of the other 98 scans, and the count of those scans is reported."""
    tracking_ms = [1.0 + 0.01 * k for k in range(98)]
    outcomes = [_outcome(ms) for ms in tracking_ms]
    outcomes += [_outcome(12.0, True), _outcome(11.0, True)]
    stats = summarise(outcomes)
    assert stats["ms_p99"] > 10.0
    assert stats["ms_p99_tracking"] == pytest.approx(float(np.percentile(tracking_ms, 99)))
    assert stats["ms_p99_tracking"] < 2.0
    assert stats["set_pose_scans"] == 2.0


def test_tracking_p99_is_nan_when_every_scan_follows_a_set_pose() -> None:
    stats = summarise([_outcome(5.0, True), _outcome(6.0, True)])
    assert math.isnan(stats["ms_p99_tracking"])
    assert stats["set_pose_scans"] == 2.0


def test_cpu_figures_are_of_the_cpu_times_not_the_wall_times() -> None:
    """A loaded machine adds other processes' time slices to a scan's wall time: the CPU
    figures summarise the CPU times (`ScanOutcome.cpu_seconds`) alone, the tracking p99
    without the scans after a set pose as the wall clock's."""
    cpu_ms = [0.5 + 0.01 * k for k in range(98)]
    outcomes = [
        ScanOutcome(
            0.01,
            0.001,
            LocaliserState.OK,
            1.0,
            (ms + (8.0 if k % 10 == 0 else 0.0)) / 1e3,  # every 10th scan pre-empted
            0.1,
            cpu_seconds=ms / 1e3,
        )
        for k, ms in enumerate(cpu_ms)
    ]
    outcomes += [
        ScanOutcome(
            0.01, 0.001, LocaliserState.OK, 1.0, 3e-3, 0.1, after_set_pose=True, cpu_seconds=2.5e-3
        )
        for _ in range(2)
    ]
    stats = summarise(outcomes)
    assert stats["ms_p99"] > 8.0
    assert stats["cpu_ms_median"] == pytest.approx(float(np.median([*cpu_ms, 2.5, 2.5])))
    assert stats["cpu_ms_p99"] == pytest.approx(float(np.percentile([*cpu_ms, 2.5, 2.5], 99)))
    assert stats["cpu_ms_p99_tracking"] == pytest.approx(float(np.percentile(cpu_ms, 99)))
