"""Where the map's walls lie in their cells, learnt from the robot's own scans (issue 12).

A scan matcher needs a *wall model*: where, inside an occupied cell, the surface a beam stops
on lies (`scan_matcher.ScanMatcherConfig.surface`). A map rasterised from a floor plan has solid
square cells whose walls lie on the cell faces (``cell_face``); a map built by binning laser
end points (GMapping, Hector, Cartographer, `mapping.grid_from_scans`) has a wall anywhere in
its cell, on average through the centre (``cell_centre``). The wrong model puts every wall half
a cell (2.5 cm at 0.05 m) off and biases the pose along the travel. It is a property of the
*map*, unknown to a robot handed a map of unknown origin: it must not be chosen per backend or
per scenario (the defect issue 12 named), so the robot finds it out from its scans, as it
learns its odometry's scale (`odometry_scale`).

**The evidence: how deep the beams end in the walls** (`beam_depths`). Along each beam, the
depth of its end point beyond the face through which the beam enters the first occupied cell
near it. On a map whose walls lie on the faces the beam stops at the face: depth 0 plus the
range noise. On a map binned from end points the wall lies anywhere in its cell: the depth is
spread over the cell, half a cell on average (more along oblique beams). The two models
predict 0 and half a cell; a scan *votes* by the median depth of its beams: ``cell_face``
below ``face_below_cells``, ``cell_centre`` above ``centre_above_cells``, no vote between. The
pose the depths are taken at is the localiser's estimate under the model it uses meanwhile;
the wrong model biases the pose by a fraction of the half cell (mostly along the travel, where
the beams ahead and behind see opposite shifts), so the medians stay apart. Measured (0.05 m
cells, per sampled scan, median depth in cells): the realistic ISR tour, seed 1, a plan-drawn
map matched with ``cell_centre`` throughout: median 0.05, 10-90 % -0.15 to 0.25, max 0.75
(167 samples); the Intel lab's map binned from its logged scans: median 0.85, 10-90 % 0.65 to
1.10 (both real-log methods). Decisions (session 9): every run of the eight real logs (both
methods, odometry seeds 0-2: 74 decisions, 3 face votes among their 592) learnt
``cell_centre``; the realistic ISR tours (seeds 1-3), Willow and Fetch (whose simulated
buildings are their grids' solid cells) learnt ``cell_face`` after 3.6-17.4 m.

**Not the matcher's residual.** Comparing the two models' best fits of a scan (the sum of
``(1 - M)²`` Hector minimises, i.e. the likelihood-ratio test) picks the right model on the
plan-drawn ISR map (residual 5-8 times lower with faces), but picks faces on the Intel lab's
binned map too, where it made the whole-log RMS 2.2 -> 4.8 cm: with corner nodes a wall one
cell thick has ``M = 1`` across the whole cell, a band that fits end points scattered through
the cell at no cost and pins the pose no better than to the band. ``M`` is not a normalised
likelihood, so its fits cannot be compared across models; the depth along the beam can.

**The decision.** Scans are sampled while the localiser tracks well (state ok, position sigma
below ``max_sigma_m``, hit fraction at least ``min_confidence``), at least ``sample_every_m``
of travel apart (other walls in view: the votes are near independent). A sequential sign test
decides: once one model leads by ``decide_margin`` votes, with at least ``min_votes`` cast, it is
the map's model, chosen once and for good (Wald's sequential probability-ratio test on the
votes: samples that vote right with probability ``p`` > 1/2 leave a wrong decision a
probability of about ``((1 - p) / p) ** decide_margin``). `WallModelLearner` holds the votes
and the decision; the localiser asks it after each scan and, if the decision differs from the
model it started with, rebuilds its matcher once, off the scan path (`matcher_swap`: swapped
in ``swap_after_s`` later on the localiser's clock).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation.scan_matcher import ScanMatcherConfig

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

SURFACES = ("cell_centre", "cell_face")
LEARN = "learn"
START_SURFACE = "cell_centre"  # what a learning localiser matches with until it has decided


class WallModelConfigError(ValueError):
    """A wall-model learning parameter is out of range; the message names it."""


class WallModelConfig(schema.Declared, frozen=True):
    """When the localiser samples scans to learn the map's wall model, and when it decides."""

    ROOT: ClassVar[str] = "WallModelConfig"
    ERROR: ClassVar[type[Exception]] = WallModelConfigError
    # Learn the model (the localiser starts with its matcher's surface and may switch once);
    # off, the matcher's surface is fixed.
    learn: bool = False
    # travel between two samples: other walls in view
    sample_every_m: Annotated[float, Meta(ge=0.0, le=100.0, extra={"unit": "m"})] = 0.5
    # sample only while the filter's largest position sigma is below this
    max_sigma_m: Annotated[float, Meta(ge=1e-3, le=1.0, extra={"unit": "m"})] = 0.05
    # ... and the scan's hit fraction is at least this
    min_confidence: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.8
    # a sample needs at least this many beams ending near an occupied cell
    min_beams: Annotated[int, Meta(ge=5, le=5000)] = 50
    # end points traced per sample, a fixed stride over the scan's valid beams (the median
    # depth needs no more; 400, the matcher's, cost 0.5-0.9 ms per sample)
    sample_beams: Annotated[int, Meta(ge=20, le=5000)] = 160
    # a sample whose median depth [cells] is below this votes cell_face ...
    face_below_cells: Annotated[float, Meta(ge=-1.0, le=2.0)] = 0.2
    # ... above this cell_centre; between, it does not vote
    centre_above_cells: Annotated[float, Meta(ge=-1.0, le=2.0)] = 0.4
    # decide when one model leads by this many votes ...
    decide_margin: Annotated[int, Meta(ge=1, le=1000)] = 6
    # ... with at least this many votes cast
    min_votes: Annotated[int, Meta(ge=1, le=1000)] = 8
    # the matcher with the learnt model is built off the scan path and swapped in at the first
    # well-tracked scan this long after the decision, on the localiser's clock (`matcher_swap`;
    # the build takes 0.2-0.4 s of CPU; 0: at the deciding scan, waiting for the build)
    swap_after_s: Annotated[float, Meta(ge=0.0, le=60.0, extra={"unit": "s"})] = 1.0

    def check(self) -> None:
        if self.face_below_cells > self.centre_above_cells:
            raise WallModelConfigError(
                f"WallModelConfig.face_below_cells ({self.face_below_cells}) must not exceed "
                f"centre_above_cells ({self.centre_above_cells})"
            )


def wall_model_setting(map_surface: str) -> tuple[ScanMatcherConfig, WallModelConfig]:
    """The matcher and learning configuration for the daemon's ``localiser.map_surface``:
    ``learn`` starts with `START_SURFACE` (true on average for maps built from laser end
    points, the maps real robots use) and learns; ``cell_centre`` / ``cell_face`` are fixed."""
    if map_surface == LEARN:
        return ScanMatcherConfig(surface=START_SURFACE), WallModelConfig(learn=True)
    return ScanMatcherConfig(surface=map_surface), WallModelConfig(learn=False)


def beam_depths(
    grid: OccupancyGrid, points: FloatArray, pose: Pose2D, reach_m: float = 0.15
) -> FloatArray:
    """How far [m] each beam's end point lies beyond the face through which the beam enters
    the first occupied cell within ``reach_m`` of its end point, along the beam (positive:
    inside the cell). Beams with no occupied cell within ``reach_m`` of their end point, or
    whose stretch starts inside one, are left out.

    ``pose`` is the laser's; ``points`` its end points (N, 2) in the laser frame. Each beam is
    sampled every tenth of a cell from ``reach_m`` before its end point to ``reach_m`` beyond;
    the entry lies half-way between the last free sample and the first occupied one.
    """
    res = grid.resolution
    step = 0.1 * res
    t = np.arange(-reach_m, reach_m + 0.5 * step, step)  # offsets along the beam
    r = np.hypot(points[:, 0], points[:, 1])
    keep = r > reach_m + step
    points, r = points[keep], r[keep]
    ux, uy = points[:, 0] / r, points[:, 1] / r
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    dx, dy = c * ux - s * uy, s * ux + c * uy  # beam directions in the map frame
    along = r[:, None] + t[None, :]
    cols = np.floor((pose.x + dx[:, None] * along - grid.origin_x) / res).astype(np.intp)
    rows = np.floor((pose.y + dy[:, None] * along - grid.origin_y) / res).astype(np.intp)
    inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
    occ = np.zeros(along.shape, dtype=bool)
    occ[inside] = grid.occupied()[rows[inside], cols[inside]]
    hit = occ.any(axis=1) & ~occ[:, 0]
    entry = t[np.argmax(occ, axis=1)] - 0.5 * step
    depths: FloatArray = -entry[hit]
    return depths


@dataclass(frozen=True)
class WallModelStatus:
    """What the operator and the benches read: the model in use, whether it is still being
    learnt or was learnt, the votes so far and the travel [m] at the decision (NaN before)."""

    surface: str
    learning: bool  # still collecting votes
    decided: bool
    votes: dict[str, int]
    samples: int  # scans sampled (votes and abstentions)
    decided_at_m: float = math.nan

    def notice(self) -> str | None:
        """The line the operator reads once the model is learnt (the station's log), else
        None."""
        if not self.decided:
            return None
        where = "on the cell faces" if self.surface == "cell_face" else "through the cell centres"
        return f"Localiser: this map's walls lie {where} (learnt after {self.decided_at_m:.1f} m)"

    def describe(self) -> str:
        votes = ", ".join(f"{k} {v}" for k, v in self.votes.items())
        if self.decided:
            return f"{self.surface} (learnt: votes {votes} of {self.samples} samples)"
        if self.learning:
            return f"{self.surface} (learning: votes {votes} of {self.samples} samples)"
        return f"{self.surface} (fixed)"


def wall_model_figures(status: WallModelStatus) -> dict[str, Any]:
    """The wall model as a scenario's figures: the model in use, whether it was learnt, after
    how much travel [m] (None if not), the votes and the samples."""
    return {
        "loc_wall_model": status.surface,
        "loc_wall_model_decided": status.decided,
        "loc_wall_model_decided_at_m": (
            None if math.isnan(status.decided_at_m) else round(status.decided_at_m, 1)
        ),
        "loc_wall_model_votes": dict(status.votes),
        "loc_wall_model_samples": status.samples,
    }


class WallModelLearner:
    """The votes of the sampled scans and the once-only decision (see the module docstring)."""

    def __init__(self, config: WallModelConfig, start_surface: str) -> None:
        self.config = config
        self.surface = start_surface
        self.votes = dict.fromkeys(SURFACES, 0)
        self.samples = 0
        self.decided = False
        self.decided_at_m = math.nan
        self._last_sample_m = -math.inf

    @property
    def learning(self) -> bool:
        return self.config.learn and not self.decided

    def status(self) -> WallModelStatus:
        return WallModelStatus(
            self.surface,
            self.learning,
            self.decided,
            dict(self.votes),
            self.samples,
            self.decided_at_m,
        )

    def wants_sample(self, travel_m: float, sigma_m: float, confidence: float) -> bool:
        """Whether to sample this scan: learning, tracking well, and far enough from the
        previous sample."""
        cfg = self.config
        return (
            self.learning
            and travel_m - self._last_sample_m >= cfg.sample_every_m
            and sigma_m <= cfg.max_sigma_m
            and confidence >= cfg.min_confidence
        )

    def vote(self, depths_cells: FloatArray) -> str | None:
        """The model a scan's beam depths [cells] support, or None (too few, or in between)."""
        cfg = self.config
        if depths_cells.size < cfg.min_beams:
            return None
        median = float(np.median(depths_cells))
        if median < cfg.face_below_cells:
            return "cell_face"
        if median > cfg.centre_above_cells:
            return "cell_centre"
        return None

    def add(self, depths_cells: FloatArray, travel_m: float) -> str | None:
        """Count one sampled scan's vote (its beam depths [cells]); the decided model when this
        sample makes the votes decisive (once), else None."""
        cfg = self.config
        self._last_sample_m = travel_m
        self.samples += 1
        vote = self.vote(depths_cells)
        logger.debug(
            "wall model sample %d at %.1f m: %d beams, median depth %.2f cells: %s",
            self.samples,
            travel_m,
            depths_cells.size,
            float(np.median(depths_cells)) if depths_cells.size else math.nan,
            vote or "no vote",
        )
        if vote is None:
            return None
        self.votes[vote] += 1
        other = max(v for k, v in self.votes.items() if k != vote)
        if self.votes[vote] - other < cfg.decide_margin or sum(self.votes.values()) < cfg.min_votes:
            return None
        self.decided = True
        self.decided_at_m = travel_m
        logger.warning(
            "wall model learnt: the map's walls lie %s (votes %s over %d sampled scans, "
            "%.1f m travelled)%s",
            "on the cell faces" if vote == "cell_face" else "through the cell centres",
            self.votes,
            self.samples,
            travel_m,
            f"; the matcher switches from {self.surface}" if vote != self.surface else "",
        )
        self.surface = vote
        return vote
