"""A synthetic office for localiser tests and benchmarks: boxes, their grid, an exact ray caster.

Walls and furniture are axis-aligned boxes (x0, y0, x1, y1) [m] whose edges lie on cell faces of
the 0.05 m grid (multiples of 0.05 m), so the rasterised map's occupied cells are exactly the
boxes: the surface a beam hits is a face of an occupied cell, as in the simulator
(`robot_daemon.sim.laser_sim`) and the scan matcher's default ``surface="cell_face"``. The caster
intersects beams with the boxes exactly (the slab method: Kay and Kajiya, "Ray tracing complex
scenes", SIGGRAPH 1986), vectorised over beams x boxes.

It depends only on `interbot_core`, so the localisation tests and `bench/bench_localiser.py`
use the same world without the simulator.
"""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

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

logger = logging.getLogger(__name__)

Boxes = npt.NDArray[np.float64]
RESOLUTION = 0.05  # [m] grid cell
OFFICE_SIZE = (20.1, 14.1)  # [m] extent of the rasterised office

_OFFICE = [
    (0, 0, 20, 0.1), (0, 13.9, 20, 14), (0, 0, 0.1, 14), (19.9, 0, 20, 14),  # outer walls
    (0, 8, 7, 8.1), (8.2, 8, 20, 8.1),  # room wall, door 7..8.2
    (12, 8, 12.1, 12),  # room divider, door 12..13.9
    (5, 0, 5.1, 3), (14, 2, 14.1, 6),  # alcove walls
    (3, 5, 3.8, 5.5), (9, 4.5, 9.8, 5), (16.5, 3, 17.3, 3.5),  # desks
    (4, 11, 4.8, 11.5), (15, 11.5, 15.8, 12), (10, 2, 10.8, 2.5),
    (7, 5.5, 7.3, 5.8), (11.5, 6.3, 11.8, 6.6), (17.5, 6, 17.8, 6.3),  # pillars
]  # fmt: skip
# A 20 x 14 m office: outer walls, rooms with doors, desks and pillars (asymmetric).
OFFICE_BOXES: Boxes = np.array(_OFFICE, dtype=np.float64)


def rasterise(
    boxes: Boxes, size: tuple[float, float] = OFFICE_SIZE, resolution: float = RESOLUTION
) -> OccupancyGrid:
    """Grid (origin 0, 0) whose cells are OCCUPIED where their centre lies in a box."""
    w, h = round(size[0] / resolution), round(size[1] / resolution)
    xc = (np.arange(w) + 0.5) * resolution
    yc = (np.arange(h) + 0.5) * resolution
    occ = np.zeros((h, w), dtype=bool)
    eps = 1e-9
    for x0, y0, x1, y1 in boxes:
        cols = (xc >= x0 - eps) & (xc <= x1 + eps)
        rows = (yc >= y0 - eps) & (yc <= y1 + eps)
        occ |= rows[:, None] & cols[None, :]
    cells = np.where(occ, OCCUPIED, FREE).astype(np.int8)
    return OccupancyGrid(cells, resolution, 0.0, 0.0, 0.0, "<synthetic office>")


def office_grid() -> OccupancyGrid:
    """The office's 0.05 m occupancy grid."""
    return rasterise(OFFICE_BOXES)


def cast_ranges(
    boxes: Boxes, pose: Pose2D, angles: npt.NDArray[np.float64], max_range: float = np.inf
) -> npt.NDArray[np.float64]:
    """Range [m] from ``pose`` to the nearest box along each beam (``inf``: no hit in range).

    Slab method: a beam ``o + t d`` is inside a box for ``t`` between the largest entry and the
    smallest exit parameter over the x and y slabs; it hits when that interval is non-empty and
    starts ahead of the origin.
    """
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
    r = np.where(hit, t_near, np.inf).min(axis=1)
    out: npt.NDArray[np.float64] = np.where(r <= max_range, r, np.inf)
    return out


def utm_scan(
    boxes: Boxes, pose: Pose2D, stamp: float, rng: np.random.Generator, noise_m: float = 0.01
) -> LaserScan:
    """A simulated UTM-30LX scan (1081 beams over 270 degrees) with Gaussian range noise [m]."""
    angles = UTM30LX_ANGLE_MIN + UTM30LX_ANGLE_INCREMENT * np.arange(
        UTM30LX_BEAMS, dtype=np.float64
    )
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
    """One box row: a square of side ``2 * half`` [m] centred at (x, y)."""
    return np.array([[x - half, y - half, x + half, y + half]])
