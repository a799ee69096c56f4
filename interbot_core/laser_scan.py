"""Planar laser scans, shaped like sensor_msgs/LaserScan.

Beam ``i`` points at ``angle_min + i * angle_increment`` in the sensor frame (REP-103: 0 ahead,
positive to the left). A range outside ``[range_min, range_max]`` or non-finite means no return.
The Hokuyo UTM-30LX default: 1081 beams over 270 degrees (0.25 degree steps), 0.1-30 m, 40 Hz.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D

UTM30LX_BEAMS = 1081
UTM30LX_ANGLE_MIN = -math.radians(135.0)
UTM30LX_ANGLE_INCREMENT = math.radians(0.25)
UTM30LX_RANGE_MIN = 0.1  # [m]
UTM30LX_RANGE_MAX = 30.0  # [m]
UTM30LX_SCAN_TIME = 0.025  # [s]
# Where Interbot's laser sits in base_link (REP-105): 0.2 m ahead of the wheel axle, level.
INTERBOT_LASER_MOUNT = Pose2D(0.2, 0.0, 0.0)  # [m, m, rad]


@dataclass(frozen=True)
class LaserScan:
    """One scan: ranges [m] (float32), beam geometry, and the time it was taken [s]."""

    stamp: float
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: npt.NDArray[np.float32]

    def __post_init__(self) -> None:
        ranges = np.ascontiguousarray(self.ranges, dtype=np.float32)
        if ranges.ndim != 1 or ranges.size == 0:
            raise ValueError("LaserScan.ranges must be a non-empty 1-D array")
        if not (self.angle_increment != 0 and math.isfinite(self.angle_increment)):
            raise ValueError("LaserScan.angle_increment must be finite and non-zero")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError("LaserScan needs 0 <= range_min < range_max")
        ranges.setflags(write=False)
        object.__setattr__(self, "ranges", ranges)

    @property
    def angles(self) -> npt.NDArray[np.float64]:
        """Beam angles in the sensor frame [rad]."""
        return _beam_trig(self.ranges.size, self.angle_min, self.angle_increment)[0].copy()

    def trig(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """``(cos, sin)`` of the beam angles (read-only: shared by every scan of this beam
        geometry, so a 10 Hz stack computes them once, not in every consumer of every scan)."""
        _, cos, sin = _beam_trig(self.ranges.size, self.angle_min, self.angle_increment)
        return cos, sin

    def valid(self) -> npt.NDArray[np.bool_]:
        """Mask of beams with a usable return."""
        r = self.ranges
        return np.isfinite(r) & (r >= self.range_min) & (r <= self.range_max)

    def points(self, max_range: float | None = None) -> npt.NDArray[np.float64]:
        """Valid returns as an (N, 2) array of sensor-frame points [m]."""
        mask = self.valid()
        if max_range is not None:
            mask &= self.ranges <= max_range
        r = self.ranges[mask].astype(np.float64)
        cos, sin = self.trig()
        return np.column_stack((r * cos[mask], r * sin[mask]))


@functools.lru_cache(maxsize=8)
def _beam_trig(
    n: int, angle_min: float, angle_increment: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Beam angles [rad] of a scan geometry and their cosines and sines, read-only (a pure
    function of its arguments, kept for the few geometries a process sees)."""
    angles = angle_min + angle_increment * np.arange(n, dtype=np.float64)
    cos, sin = np.cos(angles), np.sin(angles)
    for a in (angles, cos, sin):
        a.setflags(write=False)
    return angles, cos, sin
