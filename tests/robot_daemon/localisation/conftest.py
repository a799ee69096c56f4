"""Fixtures for the localisation tests: the synthetic office world and simulated odometry.

The world (boxes, grid, exact ray caster) lives in ``synthetic_office.py`` beside this file,
shared with bench/bench_localiser.py, so these tests depend only on the localisation package.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from tests.robot_daemon.localisation.synthetic_office import (
    OFFICE_BOXES,
    Boxes,
    cast_ranges,
    rasterise,
    square,
    utm_scan,
)


class OdometrySim:
    """Odometry from true increments with scale error and noise (seeded)."""

    def __init__(self, rng: np.random.Generator, scale: float = 1.01, yaw_scale: float = 1.01):
        self.rng, self.scale, self.yaw_scale = rng, scale, yaw_scale
        self.pose = Pose2D(0.0, 0.0, 0.0)

    def step(self, prev: Pose2D, cur: Pose2D) -> Pose2D:
        inc = cur.relative_to(prev)
        noisy = Pose2D(
            inc.x * self.scale + self.rng.normal(0, 2e-4),
            inc.y * self.scale + self.rng.normal(0, 2e-4),
            inc.yaw * self.yaw_scale + self.rng.normal(0, 2e-4),
        )
        self.pose = self.pose.compose(noisy)
        return self.pose


class World:
    """What a test needs from the synthetic office (handed out by the ``world`` fixture)."""

    boxes = OFFICE_BOXES
    square = staticmethod(square)
    cast_ranges = staticmethod(cast_ranges)
    rasterise = staticmethod(rasterise)

    def __init__(self, grid: OccupancyGrid, seed: int) -> None:
        self.grid = grid
        self.rng = np.random.default_rng(seed)

    def scan(
        self, pose: Pose2D, stamp: float = 0.0, extra: Sequence[Boxes] = (), noise_m: float = 0.01
    ) -> LaserScan:
        """A UTM-30LX scan at ``pose`` of the office plus ``extra`` boxes."""
        boxes = np.vstack([OFFICE_BOXES, *extra]) if len(extra) else OFFICE_BOXES
        return utm_scan(boxes, pose, stamp, self.rng, noise_m)

    def odometry(self, scale: float = 1.01, yaw_scale: float = 1.01) -> OdometrySim:
        return OdometrySim(self.rng, scale, yaw_scale)


@pytest.fixture(scope="session")
def office_grid() -> OccupancyGrid:
    return rasterise(OFFICE_BOXES)


@pytest.fixture
def world(office_grid: OccupancyGrid) -> World:
    return World(office_grid, seed=7)
