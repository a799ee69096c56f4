"""grid_from_scans: occupancy mapping from scans with known poses."""

from __future__ import annotations

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN
from robot_daemon.localisation import Localiser
from tests.robot_daemon.localisation.log_replay import MappingError, grid_from_scans


def test_map_from_scans_reproduces_the_walls(world) -> None:
    poses = [Pose2D(2.0 + 0.5 * k, 2.0 + 0.3 * k, 0.5 * k) for k in range(8)]
    scans = [world.scan(p) for p in poses]
    grid = grid_from_scans(scans, poses, 0.05)
    occ_x, occ_y = grid.cell_to_world(*np.nonzero(grid.cells == OCCUPIED))
    truth = world.grid
    rows, cols = truth.world_to_cell(occ_x, occ_y)
    inside = truth.in_bounds(rows, cols)
    # Nearly every mapped obstacle lies on (or next to) a true obstacle cell.
    near = np.zeros(occ_x.shape, dtype=bool)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            r, c = np.clip(rows + dr, 0, truth.height - 1), np.clip(cols + dc, 0, truth.width - 1)
            near |= truth.occupied()[r, c]
    assert inside.all() and near.mean() > 0.98
    assert occ_x.size > 500
    # The robot's own positions are free, and far corners never seen stay unknown.
    for p in poses:
        assert grid.is_free(p.x, p.y)
    assert (grid.cells == UNKNOWN).any() and (grid.cells == FREE).sum() > 10_000


def test_localising_on_a_map_from_scans(world) -> None:
    poses = [Pose2D(2.0 + 0.5 * k, 2.0 + 0.3 * k, 0.5 * k) for k in range(8)]
    grid = grid_from_scans([world.scan(p) for p in poses], poses, 0.05)
    truth = Pose2D(3.2, 2.9, 1.0)
    loc = Localiser(grid)
    loc.set_initial_pose(Pose2D(3.4, 2.8, 1.1), 0.0)
    est = loc.on_scan(world.scan(truth), 0.0)
    assert est.pose is not None and est.pose.distance_to(truth) < 0.03


def test_rejects_mismatched_inputs(world) -> None:
    with pytest.raises(MappingError, match="as many poses"):
        grid_from_scans([world.scan(Pose2D(2, 2, 0))], [], 0.05)
    with pytest.raises(MappingError, match="resolution"):
        grid_from_scans([world.scan(Pose2D(2, 2, 0))], [Pose2D(2, 2, 0)], 0.0)
