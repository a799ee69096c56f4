"""The map's own error at a place (`map_echo`): what a perfect matcher on the map gives for a
noise-free scan from the truth. Where the world is the map it is the truth; where the building
stands a few centimetres off its map, it is off by that much, whatever the localiser does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import LocaliserConfig
from robot_daemon.localisation.scan_matcher import ScanMatcherConfig
from robot_daemon.scenarios.map_echo import MapEcho, nees, pose_error
from robot_daemon.sim.laser_sim import LaserConfig
from robot_daemon.sim.world import World
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, rasterise

MOUNT = Pose2D(0.2, 0.0, 0.0)
TRUTH = (Pose2D(10.0, 6.0, 0.3), Pose2D(4.0, 3.0, -2.0), Pose2D(15.0, 10.5, 1.2))
# Walls on cell faces: the office's boxes are multiples of its 5 cm cells (synthetic_office).
FACES = LocaliserConfig(matcher=ScanMatcherConfig(surface="cell_face"))


def _echo(world_shift: tuple[float, float]) -> MapEcho:
    """The office map, and a building drawn at 2 cm with every wall moved by ``world_shift``."""
    dx, dy = world_shift
    moved = OFFICE_BOXES + np.array([dx, dy, dx, dy])
    world = World(rasterise(moved, resolution=0.02))
    laser = LaserConfig(mount_x=MOUNT.x)
    return MapEcho(office_grid(), world, laser, FACES, MOUNT)


@pytest.mark.parametrize("truth", TRUTH)
def test_reference_is_the_truth_where_the_building_is_its_map(truth: Pose2D) -> None:
    ref = _echo((0.0, 0.0)).reference(truth)
    assert ref.distance_to(truth) < 0.01
    assert abs(math.remainder(ref.yaw - truth.yaw, 2 * math.pi)) < math.radians(0.3)


@pytest.mark.parametrize("truth", TRUTH)
def test_reference_is_off_by_the_building_s_offset_from_its_map(truth: Pose2D) -> None:
    """Walls 6 cm east and 4 cm south of the map's: the map-frame pose that explains the scan
    is 6 cm west and 4 cm north of the truth (the map's error, not the localiser's)."""
    ref = _echo((0.06, -0.04)).reference(truth)
    e = pose_error(ref, truth)
    assert e[0] == pytest.approx(-0.06, abs=0.012)
    assert e[1] == pytest.approx(0.04, abs=0.012)
    assert abs(e[2]) < math.radians(0.3)


def test_nees_is_the_squared_error_in_sigmas() -> None:
    cov = np.diag([0.02**2, 0.01**2, 0.01**2])
    assert nees(np.array([0.02, 0.0, 0.0]), cov) == pytest.approx(1.0)
    assert nees(np.array([0.0, 0.02, 0.01]), cov) == pytest.approx(5.0)
    assert math.isnan(nees(np.ones(3), np.zeros((3, 3))))
