"""Global localisation: branch-and-bound correlative scan matching over the whole map.

Correlative scan matching (Olson, "Real-Time Correlative Scan Matching", ICRA 2009) scores a
pose ``ξ = (x, y, θ)`` of the laser by how well the scan's end points ``p_i`` land on the map's
walls,

    score(ξ) = 1/n · Σ_i  L(T_ξ p_i),      L(c) = exp(-d(c)² / (2 σ²)),

with ``d(c)`` the distance from cell ``c`` to the nearest occupied cell. The search over every
free cell and every heading is made tractable by branch and bound (Hess, Kohler, Rapp, Andor,
"Real-Time Loop Closure in 2D LIDAR SLAM", ICRA 2016, §V): for each heading the scan is rotated
once and snapped to the grid, and a *node* ``(θ, i, j, h)`` stands for the ``2^h × 2^h`` block
of translations starting at cell ``(i, j)``. Its bound

    bound(θ, i, j, h) = 1/n · Σ_i  M_h(c_i + (i, j)),   M_h(c) = max L over [c, c + 2^h)²,

uses the precomputed *max-grid* ``M_h`` of the same block size (Hess's "precomputation
grids"), so it is never below the score of any translation in the block, and it is exact at
``h = 0``. Nodes whose bound is below the threshold cannot hold an answer and are cut.

How the search runs here (vectorised with numpy; one node is one row of a batch):

1. *Best bound first, depth first* to find an incumbent fast: from the top-level nodes with the
   best bounds, descend greedily keeping the ``beam_width`` best children per level (a batched
   form of Hess's depth-first search that explores the best bound first) to a leaf.
2. *Exact pruning, level by level*: the threshold is ``τ = max(min_score, best - keep_margin)``;
   every node with ``bound < τ`` is cut; the survivors' children are scored as one batch. What
   reaches the leaves is *every* pose scoring at least ``τ``: not only the best, but also any
   runner-up within ``keep_margin`` of it, which the decision (`relocaliser`) needs to call a
   place ambiguous.
3. *Ranked hypotheses*: the surviving leaves are reduced by non-maximum suppression (a leaf
   within ``cluster_xy_m`` and ``cluster_yaw_rad`` of a better one is a near-duplicate of it)
   and returned best first with their scores.

*Free-space points.* End points alone reward a pose whose walls the laser would see through
(a wrong room that happens to have walls where the scan ends, and a corridor wall across the
beams). So the score also reads, for up to ``max_free_points`` beams, the beam's mid point
``p_i / 2`` on a *freeness* field ``F(c) = 1 - exp(-d(c)² / (2 σ_f²))`` (``unknown_free`` on
unknown cells): a mid point must lie in free space. Both kinds of point read max-grids of their
own field, so the bound stays a true upper bound and the leaf score is

    score(ξ) = (Σ_i L(T_ξ p_i) + Σ_j F(T_ξ p_j / 2)) / (n + m).

Only translations where the laser can be are searched: known-free cells at least
``min_clearance_m`` from any occupied or unknown cell. The search grid is coarser than the map
(``resolution_m``, 0.1 m by default); the pose is refined afterwards by the local matcher.
Poses here are of the *laser* in ``map``, like the localiser's.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta
from scipy import ndimage

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

_LEVELS = 255  # likelihood quantised to uint8: 0..255
_CHUNK = 1 << 18  # gathered values per batch (a few MB: the temporaries stay in cache)


class GlobalSearchConfigError(ValueError):
    """A global-search parameter is outside its allowed range."""


def _span(low: float, high: float, unit: str = "") -> Meta:
    """The constraint of a float field in [low, high] (in ``unit``)."""
    return Meta(ge=low, le=high, extra={"unit": unit} if unit else {})


class GlobalSearchConfig(schema.Declared, frozen=True):
    """Global search parameters (SI units)."""

    ROOT: ClassVar[str] = "GlobalSearchConfig"
    ERROR: ClassVar[type[Exception]] = GlobalSearchConfigError
    # search grid; a multiple of the map's resolution
    resolution_m: Annotated[float, _span(0.01, 1.0, "m")] = 0.10
    likelihood_sigma_m: Annotated[float, _span(0.01, 2.0, "m")] = 0.10  # σ of the likelihood L
    # headings searched: 2π / step
    angular_step_rad: Annotated[float, _span(0.002, 0.5, "rad")] = math.radians(1.5)
    # end points farther than this are not used
    max_range_m: Annotated[float, _span(1.0, 100.0, "m")] = 30.0
    # voxel filter of the end points (sensor frame)
    point_spacing_m: Annotated[float, _span(0.0, 2.0, "m")] = 0.25
    max_points: Annotated[int, Meta(ge=10, le=255)] = 80  # end points used at most
    # fewer valid end points: no search (nothing to match)
    min_points: Annotated[int, Meta(ge=3, le=255)] = 20
    depth: Annotated[int, Meta(ge=1, le=10)] = 6  # top-level blocks are 2^depth search cells wide
    # Headings per node at each level, finest (must be 1) to top: a node of level h covers
    # angle_groups[h] neighbouring headings as well as its 2^h x 2^h translations.
    angle_groups: tuple[int, ...] = (1, 1, 2, 4, 4, 8, 8)
    min_score: Annotated[float, _span(0.0, 1.0)] = 0.35  # leaves below this are never hypotheses
    # Hypotheses scoring at least best - keep_margin are all kept. (0.035 with mid points: they
    # score about 1 at every pose a scan fits, so differences shrink to 2/3 of the end points'.)
    keep_margin: Annotated[float, _span(0.0, 1.0)] = 0.035
    # nodes per level in the greedy first descent
    beam_width: Annotated[int, Meta(ge=1, le=10000)] = 2000
    # a level with more nodes than this gets a fresh dive ...
    redive_above: Annotated[int, Meta(ge=1, le=10**8)] = 20000
    redive_width: Annotated[int, Meta(ge=1, le=10**6)] = 200  # ... from this many of its best
    # nodes kept per level at most (best bounds); beyond: incomplete
    max_nodes: Annotated[int, Meta(ge=100, le=10**8)] = 30000
    max_hypotheses: Annotated[int, Meta(ge=1, le=1000)] = 16  # ranked hypotheses returned at most
    # near-duplicate: this close in position ...
    cluster_xy_m: Annotated[float, _span(0.0, 10.0, "m")] = 0.6
    # ... and in heading to a better hypothesis
    cluster_yaw_rad: Annotated[float, _span(0.0, math.pi, "rad")] = 0.35
    # the laser is at least this far from occupied/unknown
    min_clearance_m: Annotated[float, _span(0.0, 2.0, "m")] = 0.10
    # End points on unknown cells next to free space (glass, clutter the mapping run did not
    # resolve: Willow Garage) count this much of a hit; 0 = only occupied cells are walls.
    unknown_weight: Annotated[float, _span(0.0, 1.0)] = 0.5
    # beam mid points that must lie in free space (0: end points only)
    max_free_points: Annotated[int, Meta(ge=0, le=255)] = 40
    # beams shorter than this give no free-space point
    free_min_range_m: Annotated[float, _span(0.0, 100.0, "m")] = 1.0
    free_sigma_m: Annotated[float, _span(0.005, 2.0, "m")] = 0.05  # σ_f of the freeness field F
    unknown_free: Annotated[float, _span(0.0, 1.0)] = 0.5  # F on unknown cells, beyond the map
    # Nodes above this level count every mid point as 255 (F's largest value: still a bound)
    # instead of reading F: a window that wide holds free space anyway, so reading it costs
    # time and tightens nothing.
    free_max_level: Annotated[int, Meta(ge=0, le=10)] = 2

    def check(self) -> None:
        groups = self.angle_groups
        if len(groups) != self.depth + 1 or groups[0] != 1:
            raise GlobalSearchConfigError(
                f"GlobalSearchConfig.angle_groups needs depth + 1 = {self.depth + 1} entries "
                f"starting with 1, got {groups}"
            )
        for a, b in itertools.pairwise(groups):
            if b < a or b % a or b & (b - 1):
                raise GlobalSearchConfigError(
                    "GlobalSearchConfig.angle_groups must be non-decreasing powers of two, "
                    f"got {groups}"
                )
        if self.min_points > self.max_points:
            raise GlobalSearchConfigError("GlobalSearchConfig.min_points must be <= max_points")
        if self.max_points + self.max_free_points > 257:
            # A node's bound is a sum of at most 257 values of at most 255: it fits 16 bits.
            raise GlobalSearchConfigError(
                "GlobalSearchConfig.max_points + max_free_points must be <= 257"
            )


@dataclass(frozen=True)
class Hypothesis:
    """One place the robot may be: the laser's pose in ``map`` and its correlative score."""

    pose: Pose2D
    score: float  # mean likelihood of the end points, 0..1


@dataclass(frozen=True)
class SearchResult:
    """Ranked hypotheses (best first; near-duplicates removed) and what the search cost."""

    hypotheses: tuple[Hypothesis, ...]
    points_used: int
    nodes_evaluated: int
    threshold: float  # every pose scoring at least this was found (0 if no search ran) ...
    complete: bool = True  # ... unless the node budget cut the search (then some may be missing)

    @property
    def best(self) -> Hypothesis | None:
        return self.hypotheses[0] if self.hypotheses else None


@dataclass(frozen=True)
class SearchRegion:
    """An axis-aligned box of the map frame [m] to which the laser's position is restricted."""

    x_min: float
    y_min: float
    x_max: float
    y_max: float

    def __post_init__(self) -> None:
        vals = (self.x_min, self.y_min, self.x_max, self.y_max)
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"SearchRegion must be finite, got {vals}")
        if not (self.x_min < self.x_max and self.y_min < self.y_max):
            raise ValueError(f"SearchRegion needs min < max, got {vals}")

    @staticmethod
    def around(x: float, y: float, radius: float) -> SearchRegion:
        return SearchRegion(x - radius, y - radius, x + radius, y + radius)


def select_points(points: FloatArray, max_range_m: float, spacing_m: float, cap: int) -> FloatArray:
    """End points for the search: within ``max_range_m``, one per ``spacing_m`` voxel (so near
    walls do not outvote far ones), at most ``cap`` (fixed stride, deterministic)."""
    if points.shape[0] == 0:
        return points
    r2 = np.einsum("ij,ij->i", points, points)
    pts = points[r2 <= max_range_m**2]
    if spacing_m > 0.0 and pts.shape[0]:
        keys = np.floor(pts / spacing_m).astype(np.int64)
        _, first = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)
        pts = pts[np.sort(first)]
    if pts.shape[0] > cap:
        pts = pts[np.linspace(0, pts.shape[0] - 1, cap).round().astype(np.intp)]
    out: FloatArray = pts
    return out


def select_free_points(
    points: FloatArray, max_range_m: float, min_range_m: float, spacing_m: float, cap: int
) -> FloatArray:
    """Mid points of the beams between ``min_range_m`` and ``max_range_m`` long (sensor frame),
    one per ``spacing_m`` voxel, at most ``cap``: where the beam passed, free space."""
    if points.shape[0] == 0 or cap == 0:
        return np.zeros((0, 2))
    r2 = np.einsum("ij,ij->i", points, points)
    keep = (r2 >= min_range_m**2) & (r2 <= max_range_m**2)
    return select_points(0.5 * points[keep], math.inf, spacing_m, cap)


class GlobalSearch:
    """Branch-and-bound correlative search of one scan over the whole map (precomputed once)."""

    def __init__(self, grid: OccupancyGrid, config: GlobalSearchConfig | None = None) -> None:
        self.config = cfg = config or GlobalSearchConfig()
        factor = max(1, round(cfg.resolution_m / grid.resolution))
        self.grid = grid
        self.factor = factor
        self.resolution = res = grid.resolution * factor
        occ = grid.occupied()
        fine_dist = (
            np.asarray(ndimage.distance_transform_edt(~occ), dtype=np.float64) * grid.resolution
            if occ.any()
            else np.full(occ.shape, np.inf)
        )
        fine_clear = (
            np.asarray(ndimage.distance_transform_edt(~grid.blocked()), dtype=np.float64)
            * grid.resolution
        )
        self.fine_distance = fine_dist  # [m] map cell -> nearest occupied cell (verification)
        self.fine_blocked_distance = fine_clear  # [m] ... -> nearest occupied or unknown cell
        # Coarse cells: the nearest wall from anywhere in the block (min distance), and whether
        # the laser can stand somewhere in the block (max clearance).
        dist = _block_reduce(fine_dist, factor, np.min, np.inf)
        clear = _block_reduce(fine_clear, factor, np.max, 0.0)
        self.height, self.width = dist.shape
        likelihood = np.exp(-0.5 * (dist / cfg.likelihood_sigma_m) ** 2)
        if cfg.unknown_weight > 0.0:
            blocked = _block_reduce(fine_clear, factor, np.min, np.inf)
            unknown = np.exp(-0.5 * (blocked / cfg.likelihood_sigma_m) ** 2)
            likelihood = np.maximum(likelihood, cfg.unknown_weight * unknown)
        lik8 = np.rint(likelihood * _LEVELS).astype(np.uint8)
        # Freeness F of the beams' mid points: 0 on walls, 1 well clear of them, unknown_free
        # where the block holds an unknown cell (and beyond the map).
        freeness = 1.0 - np.exp(-0.5 * (dist / cfg.free_sigma_m) ** 2)
        unknown = grid.blocked() & ~occ
        if unknown.any():
            unknown_block = _block_reduce(unknown.astype(np.float64), factor, np.max, 1.0) > 0
            freeness[unknown_block] = np.minimum(freeness[unknown_block], cfg.unknown_free)
        free8 = np.rint(freeness * _LEVELS).astype(np.uint8)
        free_fill = round(cfg.unknown_free * _LEVELS)

        # Padded max-grids, all levels of both fields in one flat array: field f (0: L of the
        # end points, 1: F of the mid points), level k at [(f * levels + k) * level_size, ...).
        # L is 0 beyond the map, F unknown_free. Any point within max_range of any searched
        # translation stays inside. Each field's last level is all 255 (no bound at all) for
        # windows wider than the widest max-grid.
        top = 1 << cfg.depth
        self.pad = pad = math.ceil(cfg.max_range_m / res) + 2
        hp = -(-self.height // top) * top
        wp = -(-self.width // top) * top
        self.stride = stride = wp + 2 * pad
        rows = hp + 2 * pad
        self.level_size = rows * stride
        self.max_level = max_level = cfg.depth + 3
        self.field_levels = levels = max_level + 2
        grids = np.zeros((2 * levels, rows, stride), dtype=np.uint8)
        for f, (field_u8, fill) in enumerate(((lik8, 0), (free8, free_fill))):
            base = grids[f * levels]
            base[:] = fill
            base[pad : pad + self.height, pad : pad + self.width] = field_u8
            for k in range(1, max_level + 1):
                s = 1 << (k - 1)
                prev, cur = grids[f * levels + k - 1], grids[f * levels + k]
                cur[:] = prev
                np.maximum(cur[:-s, :], prev[s:, :], out=cur[:-s, :])
                tmp = cur.copy()
                np.maximum(cur[:, :-s], tmp[:, s:], out=cur[:, :-s])
            grids[f * levels + max_level + 1] = _LEVELS
        self._grids = grids.reshape(-1)
        # Gathers are memory-bound: 32-bit indices halve the index traffic where they fit.
        self._index_dtype = np.int32 if self._grids.size < 2**31 else np.intp

        # Where the laser may be, and per level which blocks hold any such cell.
        cand = np.zeros((hp, wp), dtype=bool)
        cand[: self.height, : self.width] = clear >= max(cfg.min_clearance_m, 1e-9)
        self.candidates = cand
        self._cand_blocks: list[npt.NDArray[np.bool_]] = [cand]
        for h in range(1, cfg.depth + 1):
            b = 1 << h
            blocks: npt.NDArray[np.bool_] = np.any(
                cand.reshape(hp // b, b, wp // b, b), axis=(1, 3)
            )
            self._cand_blocks.append(blocks)
        group_top = cfg.angle_groups[-1]
        n_angles = max(1, round(2.0 * math.pi / cfg.angular_step_rad / group_top)) * group_top
        self.angles = np.arange(n_angles) * (2.0 * math.pi / n_angles)

    # ------------------------------------------------------------------ search

    def search(
        self,
        points: FloatArray,
        region: SearchRegion | None = None,
        exclude: Sequence[Pose2D] = (),
        max_nodes: int | None = None,
        keep_margin: float | None = None,
    ) -> SearchResult:
        """Every pose of the laser scoring within ``keep_margin`` of the best, ranked.

        ``points`` are the scan's end points in the laser frame (N, 2) [m]; ``region`` limits
        the laser's position (the "Help me!" room); headings are always all searched.
        ``exclude``: laser poses already shown wrong (by verification); leaves within
        ``cluster_xy_m`` and ``cluster_yaw_rad`` of one are not answers, so the search
        returns the best places *besides* them. ``max_nodes`` overrides the node budget per
        level (a larger one for a search that must be exhaustive); ``keep_margin`` overrides
        the configured one (a wider band for places people may have cost score).
        """
        cfg = self.config
        budget = cfg.max_nodes if max_nodes is None else max_nodes
        if budget < 1:
            raise GlobalSearchConfigError(f"max_nodes must be >= 1, got {budget}")
        margin = cfg.keep_margin if keep_margin is None else keep_margin
        if not 0.0 <= margin <= 1.0:
            raise GlobalSearchConfigError(f"keep_margin must be in [0, 1], got {margin}")
        excl = _pose_array(exclude)
        offsets, n_end = self.search_offsets(points)
        n = int(offsets[0].shape[1])
        if n_end < cfg.min_points:
            return SearchResult((), n, 0, 0.0)
        evaluated = 0
        top = cfg.depth
        grp, ii, jj = self._top_nodes(region)
        if grp.size == 0:
            return SearchResult((), n, 0, 0.0)
        sums = self._bounds(offsets[top], grp, ii, jj, n)
        evaluated += grp.size
        to_int = _LEVELS * n

        # 1. Greedy best-bound-first descent for an incumbent (a real leaf score).
        order = _best(sums, cfg.beam_width)
        incumbent, cost = self._dive(top, offsets, grp[order], ii[order], jj[order], region, excl)
        evaluated += cost
        tau = max(cfg.min_score, incumbent - margin)
        tau_int = math.ceil(tau * to_int - 1e-6)

        # 2. Exact pruning level by level: every leaf with score >= tau survives.
        keep_mask = sums >= tau_int
        grp, ii, jj = grp[keep_mask], ii[keep_mask], jj[keep_mask]
        dropped = -1  # the best bound the node budget cut (quantised; -1: none)
        for h in range(top, 0, -1):
            grp, ii, jj = self._children(h, grp, ii, jj, region)
            if grp.size == 0:
                break
            sums = self._bounds(offsets[h - 1], grp, ii, jj, n)
            evaluated += grp.size
            if h - 1 >= 2 and sums.size > cfg.redive_above:
                # Many nodes left: dive again from this level's best bounds; a better
                # incumbent raises tau before the (larger) finer levels are expanded.
                order = _best(sums, cfg.redive_width)
                leaf, cost = self._dive(
                    h - 1, offsets, grp[order], ii[order], jj[order], region, excl
                )
                evaluated += cost
                tau = max(tau, leaf - margin)
                tau_int = math.ceil(tau * to_int - 1e-6)
            if h == 1 and excl.size:
                sums[self._excluded(excl, grp, ii, jj)] = 0
            if h == 1 and sums.size:
                tau = max(tau, float(sums.max()) / to_int - margin)
                tau_int = math.ceil(tau * to_int - 1e-6)
            keep_mask = sums >= tau_int
            grp, ii, jj, sums = grp[keep_mask], ii[keep_mask], jj[keep_mask], sums[keep_mask]
            if grp.size > budget:
                # Too many nodes to expand in time: keep the best bounds. No leaf under a
                # dropped node scores above its bound, so the answer stays complete as long
                # as the final threshold ends above every dropped bound (checked below);
                # otherwise it may miss places (the decision treats that as ambiguous
                # unless verification settles it).
                part = np.argpartition(sums, sums.size - budget)
                dropped = max(dropped, int(sums[part[: sums.size - budget]].max()))
                best = part[-budget:]
                grp, ii, jj, sums = grp[best], ii[best], jj[best], sums[best]
        complete = dropped < tau_int
        if grp.size == 0:
            return SearchResult((), n, evaluated, tau, complete)
        hyps = self._rank(grp, ii, jj, sums.astype(np.float64) / to_int)
        return SearchResult(hyps, n, evaluated, tau, complete)

    def _dive(
        self,
        h: int,
        offsets: list[IntArray],
        grp: IntArray,
        ii: IntArray,
        jj: IntArray,
        region: SearchRegion | None,
        excl: FloatArray,
    ) -> tuple[float, int]:
        """Best leaf score found by descending from level-``h`` nodes keeping, per level, the
        nodes with the best bounds (a batched depth-first, best-bound-first search; Hess et al.
        2016 §V.C); and the number of nodes it evaluated."""
        width = grp.size
        n = offsets[0].shape[1]
        cost = 0
        for level in range(h, 0, -1):
            grp, ii, jj = self._children(level, grp, ii, jj, region)
            if grp.size == 0:
                return 0.0, cost
            sums = self._bounds(offsets[level - 1], grp, ii, jj, n)
            cost += grp.size
            if level == 1 and excl.size:
                sums[self._excluded(excl, grp, ii, jj)] = 0
            keep = _best(sums, width)
            grp, ii, jj = grp[keep], ii[keep], jj[keep]
            if level == 1:
                return float(sums[keep[0]]) / (_LEVELS * n), cost
        return 0.0, cost

    def score(self, points: FloatArray, pose: Pose2D) -> float:
        """The correlative score of one laser pose (same points and field as the search)."""
        pts, fields = self._points(points)
        if pts.shape[0] == 0:
            return 0.0
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        x = pose.x + c * pts[:, 0] - s * pts[:, 1]
        y = pose.y + s * pts[:, 0] + c * pts[:, 1]
        col = np.floor((x - self.grid.origin_x) / self.resolution).astype(np.intp)
        row = np.floor((y - self.grid.origin_y) / self.resolution).astype(np.intp)
        col = np.clip(col + self.pad, 0, self.stride - 1)
        row = np.clip(row + self.pad, 0, self.level_size // self.stride - 1)
        vals = self._grids[row * self.stride + col + fields * (self.field_levels * self.level_size)]
        return float(vals.mean()) / _LEVELS

    def search_offsets(self, points: FloatArray) -> tuple[list[IntArray], int]:
        """The search's point windows per level (see `_level_offsets`) and the number of end
        points among them (the rest are free-space mid points, read only up to level
        ``free_max_level``: above it `_bounds` counts each as 255)."""
        pts, fields = self._points(points)
        n_end = int(np.count_nonzero(fields == 0))
        offsets = self._level_offsets(pts, fields)
        for h in range(self.config.free_max_level + 1, len(offsets)):
            offsets[h] = offsets[h][:, :n_end]
        return offsets, n_end

    # -------------------------------------------------------------- internals

    def _points(self, points: FloatArray) -> tuple[FloatArray, IntArray]:
        """The end points and the free-space mid points the search uses, and each one's field
        (0: likelihood L, 1: freeness F)."""
        cfg = self.config
        ends = select_points(points, cfg.max_range_m, cfg.point_spacing_m, cfg.max_points)
        mids = select_free_points(
            points, cfg.max_range_m, cfg.free_min_range_m, cfg.point_spacing_m, cfg.max_free_points
        )
        fields = np.repeat(np.array([0, 1], dtype=np.intp), (ends.shape[0], mids.shape[0]))
        return np.vstack((ends, mids)), fields

    def _level_offsets(self, pts: FloatArray, fields: IntArray) -> list[IntArray]:
        """Per level h, flat offsets (n_groups_h, n) of each point's bounding window (in its
        field's max-grids: ``fields`` 0 for end points, 1 for free-space mid points).

        For a node of level h (angle group ``g``, block ``[i, i + 2^h)²``) end point ``p``
        lands, over the group's headings and the block's translations, inside the rectangle
        ``(i, j) + [lo_p, hi_p + 2^h)``, where ``lo_p``/``hi_p`` are the extremes of its
        grid-snapped rotated offsets over the group. The max-grid of the smallest level ``k``
        with ``2^k`` covering that rectangle, anchored at its low corner, bounds every leaf
        under the node; windows wider than the largest max-grid read the all-255 level.
        """
        cfg = self.config
        c, s = np.cos(self.angles)[:, None], np.sin(self.angles)[:, None]
        px, py = pts[:, 0][None, :], pts[:, 1][None, :]
        dcol = np.rint((c * px - s * py) / self.resolution).astype(np.intp)
        drow = np.rint((s * px + c * py) / self.resolution).astype(np.intp)
        n_ang, n = dcol.shape
        # Each end point is scored by the best cell within half a heading step of its arc, so
        # a far wall still counts at the heading nearest the truth (Olson's blurred cost).
        reach = np.hypot(pts[:, 0], pts[:, 1]) * (math.pi / n_ang) / self.resolution
        e = np.floor(reach + 0.5).astype(np.intp)[None, :]
        field_base = (fields * self.field_levels)[None, :]
        out: list[IntArray] = []
        for h in range(cfg.depth + 1):
            g = cfg.angle_groups[h]
            r = drow.reshape(n_ang // g, g, n)
            q = dcol.reshape(n_ang // g, g, n)
            lo_r, lo_c = r.min(axis=1) - e, q.min(axis=1) - e
            span = np.maximum(r.max(axis=1) + e - lo_r, q.max(axis=1) + e - lo_c) + (1 << h)
            level = np.ceil(np.log2(span)).astype(np.intp)
            np.minimum(level, self.max_level + 1, out=level)
            flat = lo_r * self.stride + lo_c + (level + field_base) * self.level_size
            out.append(flat.astype(self._index_dtype))
        return out

    def _top_nodes(self, region: SearchRegion | None) -> tuple[IntArray, IntArray, IntArray]:
        h = self.config.depth
        bi, bj = np.nonzero(self._cand_blocks[h])
        ii, jj = bi.astype(np.intp) << h, bj.astype(np.intp) << h
        if region is not None:
            inside = self._blocks_overlap(region, ii, jj, 1 << h)
            ii, jj = ii[inside], jj[inside]
        n_grp = self.angles.size // self.config.angle_groups[h]
        grp = np.repeat(np.arange(n_grp, dtype=np.intp), ii.size)
        return grp, np.tile(ii, n_grp), np.tile(jj, n_grp)

    def _blocks_overlap(
        self, region: SearchRegion, ii: IntArray, jj: IntArray, size: int
    ) -> npt.NDArray[np.bool_]:
        g, r = self.grid, self.resolution
        c0 = math.floor((region.x_min - g.origin_x) / r)
        c1 = math.floor((region.x_max - g.origin_x) / r)
        r0 = math.floor((region.y_min - g.origin_y) / r)
        r1 = math.floor((region.y_max - g.origin_y) / r)
        out: npt.NDArray[np.bool_] = (
            (jj + size - 1 >= c0) & (jj <= c1) & (ii + size - 1 >= r0) & (ii <= r1)
        )
        return out

    def _children(
        self, h: int, grp: IntArray, ii: IntArray, jj: IntArray, region: SearchRegion | None
    ) -> tuple[IntArray, IntArray, IntArray]:
        """The level h - 1 nodes under each node: its heading groups split as the schedule
        says, times the four sub-blocks that hold a candidate cell (and meet ``region``)."""
        groups = self.config.angle_groups
        split = groups[h] // groups[h - 1]
        if split > 1:
            grp = (grp[:, None] * split + np.arange(split, dtype=np.intp)[None, :]).reshape(-1)
            ii = np.repeat(ii, split)
            jj = np.repeat(jj, split)
        s = 1 << (h - 1)
        c_grp = np.repeat(grp, 4)
        c_i = (ii[:, None] + np.array([0, 0, s, s], dtype=np.intp)[None, :]).reshape(-1)
        c_j = (jj[:, None] + np.array([0, s, 0, s], dtype=np.intp)[None, :]).reshape(-1)
        ok = self._cand_blocks[h - 1][c_i >> (h - 1), c_j >> (h - 1)]
        if region is not None:
            ok &= self._blocks_overlap(region, c_i, c_j, s)
        return c_grp[ok], c_i[ok], c_j[ok]

    def _bounds(
        self, offsets: IntArray, grp: IntArray, ii: IntArray, jj: IntArray, n_points: int
    ) -> npt.NDArray[np.int64]:
        """Σ_p M(window_p + (i, j)) per node, in quantised units (exact scores at h = 0).

        Nodes are taken heading group by heading group, so each batch adds one row of
        offsets to a column of block bases (a broadcast, not a gather of offsets). With at
        most 255 points of at most 255 each, a sum fits in 16 bits.
        """
        base = ((ii + self.pad) * self.stride + jj + self.pad).astype(self._index_dtype)
        n = offsets.shape[1]
        order = np.argsort(grp.astype(np.int16), kind="stable")  # a radix sort: < 2^15 groups
        g_sorted, b_sorted = grp[order], base[order]
        cuts = np.flatnonzero(np.diff(g_sorted)) + 1
        starts = np.concatenate(([0], cuts)).tolist()
        ends = np.concatenate((cuts, [grp.size])).tolist()
        sums = np.empty(grp.size, dtype=np.uint16)
        grids = self._grids
        step = max(1, _CHUNK // n)
        for s0, e0 in zip(starts, ends, strict=True):
            row = offsets[g_sorted[s0]]
            for s in range(s0, e0, step):
                e = min(e0, s + step)
                idx = b_sorted[s:e, None] + row
                np.sum(grids.take(idx), axis=1, dtype=np.uint16, out=sums[s:e])
        out = np.empty(grp.size, dtype=np.int64)
        out[order] = sums
        if n < n_points:
            out += _LEVELS * (n_points - n)  # mid points not read: their largest value
        return out

    def _excluded(
        self, excl: FloatArray, grp: IntArray, ii: IntArray, jj: IntArray
    ) -> npt.NDArray[np.bool_]:
        """Which leaves (heading ``grp``, cell ``(ii, jj)``) are near-duplicates of an
        excluded laser pose (rows of ``excl``: x, y, yaw)."""
        cfg = self.config
        g, r = self.grid, self.resolution
        out = np.zeros(grp.size, dtype=bool)
        xs = g.origin_x + (jj + 0.5) * r
        ys = g.origin_y + (ii + 0.5) * r
        yaws = self.angles[grp]
        for x, y, yaw in excl:
            near = np.hypot(xs - x, ys - y) <= cfg.cluster_xy_m
            near &= np.abs((yaws - yaw + math.pi) % (2.0 * math.pi) - math.pi) <= (
                cfg.cluster_yaw_rad
            )
            out |= near
        return out

    def _rank(
        self, ang: IntArray, ii: IntArray, jj: IntArray, scores: FloatArray
    ) -> tuple[Hypothesis, ...]:
        """Best first, each leaf within the cluster radius of a better one dropped."""
        cfg = self.config
        order = np.argsort(-scores, kind="stable")
        g, r = self.grid, self.resolution
        xs = g.origin_x + (jj[order] + 0.5) * r
        ys = g.origin_y + (ii[order] + 0.5) * r
        yaws = self.angles[ang[order]]
        sc = scores[order]
        alive = np.ones(order.size, dtype=bool)
        out: list[Hypothesis] = []
        k = 0
        while k < order.size and len(out) < cfg.max_hypotheses:
            if not alive[k]:
                k += 1
                continue
            out.append(Hypothesis(Pose2D(float(xs[k]), float(ys[k]), float(yaws[k])), float(sc[k])))
            dyaw = np.abs((yaws - yaws[k] + math.pi) % (2.0 * math.pi) - math.pi)
            near = (np.hypot(xs - xs[k], ys - ys[k]) <= cfg.cluster_xy_m) & (
                dyaw <= cfg.cluster_yaw_rad
            )
            alive &= ~near
            k += 1
        return tuple(out)


def _pose_array(poses: Sequence[Pose2D]) -> FloatArray:
    """(N, 3) rows of x, y, yaw."""
    return np.array([(p.x, p.y, p.yaw) for p in poses], dtype=np.float64).reshape(-1, 3)


def _best(values: npt.NDArray[np.int64], k: int) -> IntArray:
    """Indices of the ``k`` largest ``values``, largest first."""
    if values.size > k:
        top = np.argpartition(values, values.size - k)[values.size - k :]
        out: IntArray = top[np.argsort(values[top])[::-1]]
        return out
    order: IntArray = np.argsort(values)[::-1]
    return order


def _block_reduce(a: FloatArray, factor: int, reduce: np.ufunc | object, fill: float) -> FloatArray:
    """``a`` reduced over ``factor x factor`` blocks (the edge padded with ``fill``)."""
    if factor == 1:
        return a
    h, w = a.shape
    hp, wp = -(-h // factor) * factor, -(-w // factor) * factor
    padded = np.full((hp, wp), fill, dtype=np.float64)
    padded[:h, :w] = a
    blocks = padded.reshape(hp // factor, factor, wp // factor, factor)
    out: FloatArray = reduce(blocks, axis=(1, 3))  # type: ignore[operator]
    return out
