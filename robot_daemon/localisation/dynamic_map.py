"""Evidence for new static obstacles, kept apart from the matching map (thesis §3.2).

The thesis relies on Hector SLAM to add a new static obstacle to the map while "iterating
continuously" so that a moving person is not stored permanently. Here that is explicit: scan end
points that the map does not explain (farther than a tolerance from any occupied cell) hit cells
of a separate *dynamic evidence* grid. A cell's evidence is a *streak*: a run of hits with no gap
longer than ``max_gap_s``. A cell becomes a static obstacle when its streak

* lasts at least ``promote_after_s`` seconds,
* holds at least ``min_hits`` hits, and
* spans at least ``min_travel_m`` of robot travel (so the obstacle was seen from several places,
  as Hector only updates its map after 0.4 m or 0.9 rad of motion; a person standing beside a
  parked robot is never promoted).

A person walking by hits a cell for well under a second; the gap then resets the streak, so the
hits decay away without ever being promoted. Limitation: a person standing on the same spot for
longer than ``promote_after_s`` while the robot drives around will be taken as static.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.occupancy_grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]


class DynamicMapConfigError(ValueError):
    """A dynamic-map parameter is outside its allowed range."""


class DynamicMapConfig(schema.Declared, frozen=True):
    """When unexplained hits become static obstacles."""

    ROOT: ClassVar[str] = "DynamicMapConfig"
    ERROR: ClassVar[type[Exception]] = DynamicMapConfigError
    # streak length needed
    promote_after_s: Annotated[float, Meta(ge=1.0, le=3600.0, extra={"unit": "s"})] = 20.0
    # a longer gap between hits resets the streak (at most promote_after_s)
    max_gap_s: Annotated[float, Meta(ge=0.05, le=3600.0, extra={"unit": "s"})] = 2.0
    min_hits: Annotated[int, Meta(ge=1, le=100_000)] = 20  # hits needed within the streak
    # robot travel within the streak
    min_travel_m: Annotated[float, Meta(ge=0.0, le=100.0, extra={"unit": "m"})] = 0.5

    def check(self) -> None:
        if self.max_gap_s > self.promote_after_s:
            raise DynamicMapConfigError(
                f"max_gap_s must be 0.05 s..promote_after_s, got {self.max_gap_s}"
            )


class DynamicEvidenceGrid:
    """Per-cell hit streaks on the geometry of the static map."""

    def __init__(self, grid: OccupancyGrid, config: DynamicMapConfig | None = None) -> None:
        self.config = config or DynamicMapConfig()
        self.resolution = grid.resolution
        self.origin_x, self.origin_y = grid.origin_x, grid.origin_y
        self.height, self.width = grid.height, grid.width
        n = self.height * self.width
        self._first = np.full(n, -np.inf)  # [s] start of the current streak
        self._last = np.full(n, -np.inf)  # [s] last hit
        self._hits = np.zeros(n, dtype=np.int32)
        self._travel_first = np.zeros(n)  # [m] odometer at the start of the streak
        self.promoted = np.zeros((self.height, self.width), dtype=bool)

    def active_cells(self, now: float) -> int:
        """Number of cells with a live streak (hit within ``max_gap_s``)."""
        return int(np.count_nonzero(now - self._last <= self.config.max_gap_s))

    def update(
        self, xs: FloatArray, ys: FloatArray, now: float, travel_m: float
    ) -> tuple[FloatArray, FloatArray]:
        """Record unexplained end points [m] at time ``now`` with odometer ``travel_m`` [m].

        Returns the map-frame centres of cells promoted to static by this update.
        """
        cfg = self.config
        col = np.floor((xs - self.origin_x) / self.resolution).astype(np.intp)
        row = np.floor((ys - self.origin_y) / self.resolution).astype(np.intp)
        inside = (row >= 0) & (row < self.height) & (col >= 0) & (col < self.width)
        cells = np.unique(row[inside] * self.width + col[inside])
        if cells.size == 0:
            return np.empty(0), np.empty(0)
        restart = now - self._last[cells] > cfg.max_gap_s
        restarted = cells[restart]
        self._first[restarted] = now
        self._hits[restarted] = 0
        self._travel_first[restarted] = travel_m
        self._last[cells] = now
        self._hits[cells] += 1
        ready = (
            (now - self._first[cells] >= cfg.promote_after_s)
            & (self._hits[cells] >= cfg.min_hits)
            & (travel_m - self._travel_first[cells] >= cfg.min_travel_m)
        )
        flat_promoted = self.promoted.reshape(-1)
        new = cells[ready & ~flat_promoted[cells]]
        if new.size == 0:
            return np.empty(0), np.empty(0)
        flat_promoted[new] = True
        r, c = np.divmod(new, self.width)
        return (
            self.origin_x + (c + 0.5) * self.resolution,
            self.origin_y + (r + 0.5) * self.resolution,
        )

    def reset_streaks(self) -> None:
        """Forget all live streaks (e.g. after the robot was lost); keeps promoted cells."""
        self._first.fill(-math.inf)
        self._last.fill(-math.inf)
        self._hits.fill(0)
