"""Simple occupancy mapping from scans with known poses (for tests on logged data).

A counting ("hit / pass") occupancy grid, the frequentist form of the inverse sensor model of
Thrun, Burgard and Fox, *Probabilistic Robotics*, ch. 9: every end point adds a hit to its cell,
every cell a beam passes through before it adds a pass (sampled at half the resolution along the
beam). A cell is OCCUPIED when ``hits >= min_hits`` and ``hits / (hits + passes) >= occupied_ratio``,
FREE when it was passed and is not occupied, UNKNOWN otherwise. Vectorised over the beams of each
scan.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid


class MappingError(ValueError):
    """Inputs of `grid_from_scans` are inconsistent."""


def scan_points_in_map(
    scan: LaserScan, pose: Pose2D, max_range: float | None = None
) -> npt.NDArray[np.float64]:
    """End points of the valid beams in the map frame, (N, 2) [m]."""
    pts = scan.points(max_range)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return np.column_stack(
        (pose.x + c * pts[:, 0] - s * pts[:, 1], pose.y + s * pts[:, 0] + c * pts[:, 1])
    )


def grid_from_scans(
    scans: Sequence[LaserScan],
    poses: Sequence[Pose2D],
    resolution: float,
    max_range: float = 15.0,
    margin: float = 1.0,
    min_hits: int = 2,
    occupied_ratio: float = 0.25,
) -> OccupancyGrid:
    """Build an `OccupancyGrid` from scans taken at the given sensor poses.

    ``max_range`` [m]: beams longer than this are ignored (no return is not traced either);
    ``margin`` [m] is added around the end points and poses.
    """
    if len(scans) != len(poses) or not scans:
        raise MappingError(f"need as many poses as scans (>0), got {len(scans)} and {len(poses)}")
    if not (math.isfinite(resolution) and 0.005 <= resolution <= 2.0):
        raise MappingError(f"resolution must be 0.005..2 m, got {resolution}")
    if min_hits < 1 or not 0.0 < occupied_ratio <= 1.0:
        raise MappingError("need min_hits >= 1 and 0 < occupied_ratio <= 1")
    ends = [scan_points_in_map(s, p, max_range) for s, p in zip(scans, poses, strict=True)]
    every = np.vstack([*ends, np.array([[p.x, p.y] for p in poses])])
    x0, y0 = every.min(axis=0) - margin
    x1, y1 = every.max(axis=0) + margin
    width = math.ceil((x1 - x0) / resolution)
    height = math.ceil((y1 - y0) / resolution)
    hits = np.zeros(height * width, dtype=np.int64)
    passes = np.zeros(height * width, dtype=np.int64)
    step = resolution * 0.5
    for pose, end in zip(poses, ends, strict=True):
        if end.size == 0:
            continue
        col = ((end[:, 0] - x0) / resolution).astype(np.intp)
        row = ((end[:, 1] - y0) / resolution).astype(np.intp)
        hits += np.bincount(row * width + col, minlength=height * width)
        # Free space: samples from the sensor up to one cell short of each end point.
        dx, dy = end[:, 0] - pose.x, end[:, 1] - pose.y
        length = np.hypot(dx, dy)
        n_max = int(length.max() / step)
        if n_max < 1:
            continue
        t = np.arange(n_max, dtype=np.float64) * step  # [m] along the beam
        keep = t[None, :] < (length[:, None] - resolution)
        frac = t[None, :] / np.maximum(length[:, None], 1e-9)
        sx = (pose.x + frac * dx[:, None])[keep]
        sy = (pose.y + frac * dy[:, None])[keep]
        cells = ((sy - y0) / resolution).astype(np.intp) * width + ((sx - x0) / resolution).astype(
            np.intp
        )
        passes += np.bincount(np.unique(cells), minlength=height * width)
    cells_out = np.full(height * width, UNKNOWN, dtype=np.int8)
    cells_out[passes > 0] = FREE
    occupied = (hits >= min_hits) & (hits >= occupied_ratio * (hits + passes))
    cells_out[occupied] = OCCUPIED
    return OccupancyGrid(
        cells_out.reshape(height, width), resolution, float(x0), float(y0), 0.0, "<scans>"
    )
