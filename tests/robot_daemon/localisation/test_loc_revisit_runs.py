"""`log_replay.revisit_runs`: which later scans of a log are localised together, in one run.

A run is one drive through the mapped area without a new initial pose. Synthetic poses: the
first pass drives along y = 0 with a scan every metre; the second pass comes back along the
same line, or along a parallel one.
"""

from __future__ import annotations

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from tests.robot_daemon.localisation.carmen_log import LaserRecord
from tests.robot_daemon.localisation.log_replay import (
    BRIDGE_RADIUS_M,
    REVISIT_RADIUS_M,
    revisit_runs,
)

_SCAN = LaserScan(0.0, -np.pi / 2, np.pi / 180, 0.01, 80.0, np.ones(181, dtype=np.float32))


def _record(x: float, y: float, k: int) -> LaserRecord:
    return LaserRecord(_SCAN, Pose2D(x, y, 0.0), Pose2D(x, y, 0.0), float(k), k)


def _log(second_pass_y: list[float]) -> tuple[list[LaserRecord], int]:
    """A first pass of 40 scans along y = 0 (x = 0..39 m), then the second pass at
    ``second_pass_y[k]`` for x = k (one scan per metre)."""
    first = [_record(float(x), 0.0, x) for x in range(40)]
    second = [_record(float(k), y, 40 + k) for k, y in enumerate(second_pass_y)]
    return first + second, len(first)


def test_a_second_pass_a_little_beside_the_first_is_one_run() -> None:
    """Three scans 1.3 m to the side (beyond the revisit radius, within the bridge): the drive
    goes on, as the robot's would; before, the run was cut there and the localiser restarted
    from a person's initial pose in the middle of the corridor."""
    ys = [0.2] * 15 + [1.3] * 3 + [0.2] * 15
    records, split = _log(ys)
    runs = revisit_runs(records, split, 10)
    assert REVISIT_RADIUS_M < 1.3 < BRIDGE_RADIUS_M
    assert len(runs) == 1
    assert [r.line_number for r in runs[0]] == list(range(40, 40 + len(ys)))


def test_a_run_ends_where_the_path_leaves_the_mapped_area() -> None:
    """Five scans 5 m away (a room the first pass never entered) cut the drive in two runs."""
    ys = [0.2] * 15 + [5.0] * 5 + [0.2] * 15
    records, split = _log(ys)
    runs = revisit_runs(records, split, 10)
    assert [(r[0].line_number, r[-1].line_number) for r in runs] == [(40, 54), (60, 74)]


def test_only_runs_of_their_own_are_joined() -> None:
    """Scans 1.5 m beside the first pass before the first revisit and after the last are not
    localised, and two stretches of 6 revisits each are not made a run of 12 by the scans
    between them: there the robot turns into space the first pass did not see (extending
    runs so cost CSAIL's revisit 2 -> 20-29 cm RMS)."""
    ys = [1.5] * 20 + [0.2] * 12 + [1.5] * 5
    records, split = _log(ys)
    runs = revisit_runs(records, split, 10)
    assert [(r[0].line_number, r[-1].line_number) for r in runs] == [(60, 71)]
    records, split = _log([0.2] * 6 + [1.5] * 3 + [0.2] * 6)
    assert revisit_runs(records, split, 10) == []
