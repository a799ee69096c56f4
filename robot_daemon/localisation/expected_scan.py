"""The scan a place would give, compared beam by beam with the real one (issue 16).

The relocaliser ranks places by their *end points* (how many land on a wall). Two places can
score alike that way and still be told apart by where the beams *stop*: at a wrong place many
beams run on past the walls the map has there (a corridor where the place has a door, a room
whose far wall is missing). This is the beam model's view (Thrun, Burgard, Fox, *Probabilistic
Robotics*, 2005, §6.3): each beam's measured range ``r`` is compared with the expected range
``e``, the distance along the beam to the first wall of the map,

* ``match``: ``|r - e| <= match_tolerance_m`` (the beam ends on the wall the place expects);
* ``long``: ``r > e + long_margin_m`` (the beam went *through* a wall of the place).

People and clutter only ever make beams *shorter*: a person standing in front of a wall cannot
make a beam run past it. So ``long`` is evidence against a place that people cannot fake, and
the relocaliser uses it (with ``match``) to tell a place from a look-alike whose end points fit
nearly as well (`relocaliser.Relocaliser`). Glass and doors the map has closed also make beams
long, at the true place too: so places are only compared with each other, never judged alone.

A beam whose ray meets unknown space (what the mapping run never saw) before any wall is
neither: nothing is expected there.

The expected range is found by marching along each beam in half-cell steps on the map grid
(vectorised over beams), only as far as the measured range plus the tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class BeamAgreement:
    """How the real scan agrees with the one the map predicts at a place (fractions of the
    beams compared)."""

    match: float  # beams ending on the wall the place expects
    long: float  # beams that went through a wall of the place
    beams: int  # beams compared (those that met unknown space first are left out)


class ExpectedScan:
    """Compares a scan with the map's prediction at a laser pose."""

    def __init__(
        self,
        grid: OccupancyGrid,
        max_beams: int = 180,
        match_tolerance_m: float = 0.15,
        long_margin_m: float = 0.3,
    ) -> None:
        if not (1 <= max_beams <= 10_000):
            raise ValueError(f"ExpectedScan.max_beams must be in [1, 10000], got {max_beams}")
        if not (0.0 < match_tolerance_m < long_margin_m <= 5.0):
            raise ValueError(
                "ExpectedScan needs 0 < match_tolerance_m < long_margin_m <= 5 m, got "
                f"{match_tolerance_m}, {long_margin_m}"
            )
        self.grid = grid
        self.max_beams = max_beams
        self.match_tolerance_m = match_tolerance_m
        self.long_margin_m = long_margin_m
        # 0 free, 1 occupied, 2 unknown; beyond the map: unknown.
        occ = grid.occupied()
        self._cells = np.where(occ, 1, np.where(grid.blocked(), 2, 0)).astype(np.uint8)

    def agreement(self, scan: LaserScan, pose: Pose2D) -> BeamAgreement:
        """Beam-by-beam agreement of ``scan`` with the map seen from laser pose ``pose``."""
        valid = np.flatnonzero(scan.valid())
        if valid.size == 0:
            return BeamAgreement(0.0, 0.0, 0)
        if valid.size > self.max_beams:
            valid = valid[np.linspace(0, valid.size - 1, self.max_beams).round().astype(np.intp)]
        r = scan.ranges[valid].astype(np.float64)
        angles = pose.yaw + scan.angles[valid]
        expected, unknown = self._expected(pose, angles, r + self.long_margin_m)
        known = ~unknown
        n = int(np.count_nonzero(known))
        if n == 0:
            return BeamAgreement(0.0, 0.0, 0)
        match = np.abs(r - expected) <= self.match_tolerance_m
        long = r > expected + self.long_margin_m
        return BeamAgreement(
            float(np.count_nonzero(match & known)) / n,
            float(np.count_nonzero(long & known)) / n,
            n,
        )

    def _expected(
        self, pose: Pose2D, angles: FloatArray, reach: FloatArray
    ) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        """Per beam: the distance to the first occupied cell within ``reach`` (inf if none),
        and whether the ray met an unknown cell first."""
        g = self.grid
        step = 0.5 * g.resolution
        n_steps = max(1, math.ceil(float(reach.max()) / step))
        t = (np.arange(1, n_steps + 1, dtype=np.float64) * step)[None, :]
        xs = pose.x + np.cos(angles)[:, None] * t
        ys = pose.y + np.sin(angles)[:, None] * t
        col = np.floor((xs - g.origin_x) / g.resolution).astype(np.intp)
        row = np.floor((ys - g.origin_y) / g.resolution).astype(np.intp)
        inside = (row >= 0) & (row < g.height) & (col >= 0) & (col < g.width)
        cells = np.full(xs.shape, 2, dtype=np.uint8)
        cells[inside] = self._cells[row[inside], col[inside]]
        cells[t > reach[:, None]] = 0  # beyond this beam's reach: not looked at
        stop = cells > 0
        first = np.argmax(stop, axis=1)
        hit = stop[np.arange(first.size), first]
        kind = cells[np.arange(first.size), first]
        expected = np.where(hit & (kind == 1), t[0, first], np.inf)
        unknown = hit & (kind == 2)
        return expected, unknown
