"""Expected scans (issue 16): the map's prediction at a place against the real scan, beam by beam.

A box room ray-cast exactly (`synthetic_office`). What must hold: at the true pose the beams
end where the map says; at a wrong pose many run on through its walls; a person (in the world,
not the map) only shortens beams and never makes one long; beams into unknown space are left out.
"""

from __future__ import annotations

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import UNKNOWN, OccupancyGrid
from robot_daemon.localisation.expected_scan import ExpectedScan
from tests.robot_daemon.localisation.synthetic_office import rasterise, square, utm_scan
from tests.robot_daemon.localisation.test_loc_relocaliser import ROOM

SIZE = (6.0, 5.0)
LASER = Pose2D(2.0, 1.5, 0.4)


def _scan(boxes: np.ndarray, seed: int = 1):  # type: ignore[no-untyped-def]
    return utm_scan(boxes, LASER, 0.1, np.random.default_rng(seed))


def test_at_the_true_pose_the_beams_end_where_the_map_says() -> None:
    expected = ExpectedScan(rasterise(ROOM, size=SIZE))
    a = expected.agreement(_scan(ROOM), LASER)
    assert a.beams > 100
    assert a.match > 0.95 and a.long < 0.01


def test_at_a_wrong_pose_beams_run_through_its_walls() -> None:
    expected = ExpectedScan(rasterise(ROOM, size=SIZE))
    wrong = Pose2D(4.0, 3.0, LASER.yaw + 0.5)
    a = expected.agreement(_scan(ROOM), wrong)
    assert a.long > 0.2 and a.match < 0.5


def test_a_person_only_shortens_beams() -> None:
    grid = rasterise(ROOM, size=SIZE)  # the map has no person
    people = np.vstack([ROOM, square(3.2, 1.9, 0.25)])  # the world has one, 1.3 m ahead
    expected = ExpectedScan(grid)
    clear = expected.agreement(_scan(ROOM), LASER)
    crowded = expected.agreement(_scan(people), LASER)
    assert crowded.match < clear.match - 0.03  # the beams on the person do not match ...
    assert crowded.long == pytest.approx(clear.long, abs=0.005)  # ... and none went long


def test_beams_into_unknown_space_are_left_out() -> None:
    grid = rasterise(ROOM, size=SIZE)
    cells = grid.cells.copy()
    cells[:, round(4.5 / grid.resolution) :] = UNKNOWN  # the east end was never mapped
    half = OccupancyGrid(cells, grid.resolution, 0.0, 0.0, 0.0, "east end unknown")
    expected = ExpectedScan(half)
    known = ExpectedScan(grid).agreement(_scan(ROOM), LASER)
    a = expected.agreement(_scan(ROOM), LASER)
    assert 0 < a.beams < known.beams
    assert a.long < 0.01


def test_bad_parameters_are_refused_with_their_names() -> None:
    grid = rasterise(ROOM, size=SIZE)
    with pytest.raises(ValueError, match="max_beams"):
        ExpectedScan(grid, max_beams=0)
    with pytest.raises(ValueError, match="long_margin_m"):
        ExpectedScan(grid, match_tolerance_m=0.5, long_margin_m=0.3)
