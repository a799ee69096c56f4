"""Synthetic office world for the localisation tests: boxes, their grid, and a ray caster.

Kept here (not in robot_daemon/sim) so these tests depend only on the localisation package.
Walls and furniture are axis-aligned boxes whose edges pass through cell centres of the 0.05 m
grid, so the rasterised map has no half-cell bias; the caster intersects beams with the boxes
exactly (slab method), vectorised over beams x boxes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import (
    UTM30LX_ANGLE_INCREMENT,
    UTM30LX_ANGLE_MIN,
    UTM30LX_BEAMS,
    UTM30LX_RANGE_MAX,
    UTM30LX_RANGE_MIN,
    LaserScan,
)
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid

Boxes = npt.NDArray[np.float64]
RESOLUTION = 0.05

_OFFICE = [
    (0, 0, 20, 0.1), (0, 13.9, 20, 14), (0, 0, 0.1, 14), (19.9, 0, 20, 14),  # outer walls
    (0, 8, 7, 8.1), (8.2, 8, 20, 8.1),  # room wall, door 7..8.2
    (12, 8, 12.1, 12),  # room divider
    (5, 0, 5.1, 3), (14, 2, 14.1, 6),  # alcove walls
    (3, 5, 3.8, 5.5), (9, 4.5, 9.8, 5), (16.5, 3, 17.3, 3.5),  # desks
    (4, 11, 4.8, 11.5), (15, 11.5, 15.8, 12), (10, 2, 10.8, 2.5),
    (7, 5.5, 7.3, 5.8), (11.5, 6.3, 11.8, 6.6), (17.5, 6, 17.8, 6.3),  # pillars
]  # fmt: skip
OFFICE_BOXES: Boxes = np.array(_OFFICE, dtype=np.float64) + RESOLUTION / 2


def rasterise(boxes: Boxes, size: tuple[float, float] = (20.1, 14.1)) -> OccupancyGrid:
    """Grid (origin 0, 0) with cells OCCUPIED where their centre lies in a box."""
    w, h = round(size[0] / RESOLUTION), round(size[1] / RESOLUTION)
    xc = (np.arange(w) + 0.5) * RESOLUTION
    yc = (np.arange(h) + 0.5) * RESOLUTION
    occ = np.zeros((h, w), dtype=bool)
    for x0, y0, x1, y1 in boxes:
        cols = (xc >= x0 - 1e-9) & (xc <= x1 + 1e-9)
        rows = (yc >= y0 - 1e-9) & (yc <= y1 + 1e-9)
        occ |= rows[:, None] & cols[None, :]
    return OccupancyGrid(np.where(occ, OCCUPIED, FREE).astype(np.int8), RESOLUTION, 0.0, 0.0)


def cast_ranges(
    boxes: Boxes, pose: Pose2D, angles: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Range [m] from ``pose`` to the nearest box along each beam (inf: no hit)."""
    a = pose.yaw + angles
    dx, dy = np.cos(a)[:, None], np.sin(a)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        tx0 = (boxes[None, :, 0] - pose.x) / dx
        tx1 = (boxes[None, :, 2] - pose.x) / dx
        ty0 = (boxes[None, :, 1] - pose.y) / dy
        ty1 = (boxes[None, :, 3] - pose.y) / dy
    t_near = np.maximum(np.fmin(tx0, tx1), np.fmin(ty0, ty1))
    t_far = np.minimum(np.fmax(tx0, tx1), np.fmax(ty0, ty1))
    hit = (t_near <= t_far) & (t_near > 0.0)
    out: npt.NDArray[np.float64] = np.where(hit, t_near, np.inf).min(axis=1)
    return out


def utm_scan(
    boxes: Boxes, pose: Pose2D, stamp: float, rng: np.random.Generator, noise_m: float = 0.01
) -> LaserScan:
    """A simulated UTM-30LX scan (1081 beams over 270 degrees) with Gaussian range noise."""
    angles = UTM30LX_ANGLE_MIN + UTM30LX_ANGLE_INCREMENT * np.arange(UTM30LX_BEAMS)
    r = cast_ranges(boxes, pose, angles) + rng.normal(0.0, noise_m, UTM30LX_BEAMS)
    return LaserScan(
        stamp,
        UTM30LX_ANGLE_MIN,
        UTM30LX_ANGLE_INCREMENT,
        UTM30LX_RANGE_MIN,
        UTM30LX_RANGE_MAX,
        r.astype(np.float32),
    )


def square(x: float, y: float, half: float) -> Boxes:
    """One box row: a square of side 2 * half centred at (x, y)."""
    return np.array([[x - half, y - half, x + half, y + half]])


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
