"""Map-based localiser: Hector scan matching with an odometry prior (thesis §3.2, §4.2.3.1).

The thesis runs a modified Hector SLAM against an a-priori map, started from a pose the user
gives (station or tablet), without odometry. This localiser keeps Hector's matcher
(`scan_matcher.ScanMatcher`) and adds, beyond the thesis:

* **Odometry prior.** Each scan is matched starting from ``x_pred = x_prev ⊕ (o_prev⁻¹ ⊕ o_now)``,
  the last estimate moved by the odometry increment since the previous scan. The match ``x_m``
  is then fused with the prediction in information form,
  ``x = x_pred + (Λ_p + H/s²)⁻¹ (H/s²) (x_m - x_pred)``, where ``H`` is Hector's Hessian and
  ``Λ_p`` the inverse of a prediction covariance that grows with the odometry increment. Where the
  scan constrains the pose (large ``H``) the match wins; along a featureless corridor the prior does.
* **Confidence.** The fraction of the matched end points lying within ``hit_tolerance_m`` of an
  occupied map cell, reported with Hector's score (mean ``M``).
* **Loss detection.** A scan is *bad* if its confidence is below ``lost_confidence``, if more
  than ``lost_impossible`` of its beams are *impossible* at the estimate (below), or if its
  correction ``x_m ⊖ x_pred`` is implausibly large (it is then rejected). Bad scans for
  ``lost_after_s`` seconds in a row make the state ``lost``. While lost the pose follows odometry
  alone and the state stays ``lost`` until `set_initial_pose` is called.
* **Impossible beams** (the "see-through" test of beam-based sensor models: Thrun, Burgard, Fox,
  *Probabilistic Robotics*, 2005, §6.3, where a measurement longer than the map's expected range
  has only the small "random" likelihood). A beam is impossible when its measured range passes
  more than ``impossible_margin_m`` *through* an occupied map cell: the ray from the laser,
  sphere-traced on the distance field, meets an occupied cell before ``range - margin``. People
  and new furniture only shorten beams, so this is robust to crowds, unlike the hit fraction; a
  kidnapped robot whose new surroundings resemble the old ones (every door of a corridor looks
  alike) still sees through walls somewhere. Rays that leave the map, or that the trace does not
  finish within ``impossible_max_steps`` steps (grazing a wall), count as possible.
* **New static obstacles, not people.** Unexplained end points feed a
  `dynamic_map.DynamicEvidenceGrid`; cells it promotes are added to the matching map.

Time is passed in; the localiser never reads a clock and never sees ground truth.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from interbot_core.geometry import Pose2D, wrap_angle
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OCCUPIED, OccupancyGrid
from robot_daemon.localisation.dynamic_map import DynamicEvidenceGrid, DynamicMapConfig
from robot_daemon.localisation.scan_matcher import (
    MatchResult,
    ScanMatcher,
    ScanMatcherConfig,
    subsample_points,
)

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


class LocaliserConfigError(ValueError):
    """A localiser parameter is outside its allowed range."""


class LocaliserState(StrEnum):
    """Localisation status reported with each estimate."""

    UNSET = "unset"  # no initial pose yet
    OK = "ok"
    LOST = "lost"
    SEARCHING = "searching"  # a global search is under way (reported by the stack, issue 16)


@dataclass(frozen=True)
class LocaliserConfig:
    """Localiser parameters (SI units)."""

    matcher: ScanMatcherConfig = field(default_factory=ScanMatcherConfig)
    dynamic_map: DynamicMapConfig = field(default_factory=DynamicMapConfig)
    max_range_m: float = 30.0  # beams beyond are ignored
    hit_tolerance_m: float = 0.10  # an end point this close to the map counts as a hit
    lost_confidence: float = 0.35  # a scan below this hit fraction is bad
    lost_after_s: float = 1.0  # bad scans for this long -> lost
    max_jump_m: float = 0.3  # plausible correction: this + max_jump_gain * odometry step
    max_jump_rad: float = 0.2
    max_jump_gain: float = 0.5
    odom_blend: bool = True  # fuse the match with the odometry prediction (Hessian weighting)
    match_residual_var: float = 1.0  # s² scaling H into an information matrix
    prior_sigma_m: float = 0.02  # prediction sigma: this + prior_sigma_gain * odometry step
    prior_sigma_rad: float = 0.01
    prior_sigma_gain: float = 0.2
    map_update: bool = True
    map_update_min_confidence: float = 0.6  # only learn obstacles while well localised
    unexplained_m: float = 0.2  # end points farther than this from the map are "unexplained"
    map_update_max_range_m: float = 8.0
    lost_impossible: float = 0.05  # a scan with more than this fraction of impossible beams is bad
    impossible_margin_m: float = 0.3  # a beam this much longer than the map allows is impossible
    impossible_max_beams: int = 200  # beams traced per scan (fixed stride over the valid ones)
    impossible_max_steps: int = 30  # sphere-tracing steps; unfinished rays count as possible
    impossible_min_run: int = 2  # only runs of this many neighbouring impossible beams count
    impossible_depth_m: float = 0.1  # a ray must stay this long in occupied cells to go through
    # A scan that fits the map this well (hit fraction) may see through an opening the map has
    # closed (a glass pane, a door now open): its impossible beams that END on a mapped surface
    # (within see_through_landing_m) are then not counted. A wrong pose rarely fits this well.
    see_through_min_confidence: float = 0.9
    see_through_landing_m: float = 0.15

    def __post_init__(self) -> None:
        checks: list[tuple[str, float, float, float]] = [
            ("max_range_m", self.max_range_m, 0.5, 200.0),
            ("hit_tolerance_m", self.hit_tolerance_m, 0.01, 1.0),
            ("lost_confidence", self.lost_confidence, 0.0, 1.0),
            ("lost_after_s", self.lost_after_s, 0.05, 60.0),
            ("max_jump_m", self.max_jump_m, 0.01, 10.0),
            ("max_jump_rad", self.max_jump_rad, 0.01, math.pi),
            ("max_jump_gain", self.max_jump_gain, 0.0, 10.0),
            ("match_residual_var", self.match_residual_var, 1e-6, 1e6),
            ("prior_sigma_m", self.prior_sigma_m, 1e-4, 10.0),
            ("prior_sigma_rad", self.prior_sigma_rad, 1e-5, 3.0),
            ("prior_sigma_gain", self.prior_sigma_gain, 0.0, 10.0),
            ("map_update_min_confidence", self.map_update_min_confidence, 0.0, 1.0),
            ("unexplained_m", self.unexplained_m, 0.01, 5.0),
            ("map_update_max_range_m", self.map_update_max_range_m, 0.5, 200.0),
            ("lost_impossible", self.lost_impossible, 0.0, 1.0),
            ("impossible_margin_m", self.impossible_margin_m, 0.05, 5.0),
            ("impossible_max_beams", self.impossible_max_beams, 10, 5000),
            ("impossible_max_steps", self.impossible_max_steps, 1, 1000),
            ("impossible_min_run", self.impossible_min_run, 1, 100),
            ("impossible_depth_m", self.impossible_depth_m, 0.0, 2.0),
            ("see_through_min_confidence", self.see_through_min_confidence, 0.0, 1.0),
            ("see_through_landing_m", self.see_through_landing_m, 0.0, 1.0),
        ]
        for name, value, low, high in checks:
            if not (math.isfinite(value) and low <= value <= high):
                raise LocaliserConfigError(
                    f"LocaliserConfig.{name} must be in [{low}, {high}], got {value}"
                )


@dataclass(frozen=True)
class LocaliserEstimate:
    """What the localiser reports after each scan."""

    pose: Pose2D | None  # map frame; None while unset
    state: LocaliserState
    confidence: float  # fraction of end points on the map, 0..1
    score: float  # Hector match score (mean M), 0..1
    stamp: float  # [s]
    impossible: float = 0.0  # fraction of beams passing through the map, 0..1


class Localiser:
    """Tracks the robot's pose in ``grid`` from laser scans and odometry."""

    def __init__(self, grid: OccupancyGrid, config: LocaliserConfig | None = None) -> None:
        self.config = config or LocaliserConfig()
        self._grid = grid
        self.matcher = ScanMatcher(grid, self.config.matcher)
        self.dynamic = DynamicEvidenceGrid(grid, self.config.dynamic_map)
        occ = grid.occupied()
        if occ.any():
            dist = ndimage.distance_transform_edt(~occ) * grid.resolution
        else:
            dist = np.full(occ.shape, np.inf)
        # Distance field [m] with a border of inf cells, flat (row-major, width + 2 columns):
        # ray samples clipped to the border read inf, i.e. "off the map".
        padded = np.full((grid.height + 2, grid.width + 2), np.inf)
        padded[1:-1, 1:-1] = dist
        self._dist_padded = padded.reshape(-1)
        self._dist_radius = math.ceil(max(self.config.unexplained_m, 0.5) / grid.resolution)
        k = np.arange(-self._dist_radius, self._dist_radius + 1) * grid.resolution
        self._dist_kernel = np.hypot(k[None, :], k[:, None])
        self._trig_key: tuple[int, float, float] | None = None
        self._cos = np.empty(0)
        self._sin = np.empty(0)
        self._state = LocaliserState.UNSET
        self._pose: Pose2D | None = None
        self._odom: Pose2D | None = None  # latest odometry
        self._odom_at_scan: Pose2D | None = None  # odometry at the previous scan
        self._travel_m = 0.0  # odometer [m]
        self._bad_since: float | None = None
        self._full_search = True
        self._last = LocaliserEstimate(None, LocaliserState.UNSET, 0.0, 0.0, -math.inf)

    # ------------------------------------------------------------------ inputs

    @property
    def state(self) -> LocaliserState:
        """Current localisation state."""
        return self._state

    @property
    def pose(self) -> Pose2D | None:
        """Latest pose estimate in the map frame (None while unset)."""
        return self._pose

    @property
    def current_pose(self) -> Pose2D | None:
        """The pose now: the last estimate moved by the odometry since its scan (REP-105's
        map -> odom correction applied to live odometry). Between scans at 10 Hz a robot at
        0.25 m/s moves 2.5 cm; this is the pose to act on and to publish."""
        if self._pose is None:
            return None
        if self._odom is None or self._odom_at_scan is None:
            return self._pose
        return self._pose.compose(self._odom.relative_to(self._odom_at_scan))

    @property
    def last_estimate(self) -> LocaliserEstimate:
        """The estimate returned by the last `on_scan`."""
        return self._last

    def set_initial_pose(self, pose: Pose2D, now: float) -> None:
        """Start (or restart) tracking at ``pose`` (the station, or a room picked on the tablet)."""
        logger.info(
            "initial pose set to (%.2f, %.2f, %.2f) at t=%.2f", pose.x, pose.y, pose.yaw, now
        )
        self._pose = pose
        self._state = LocaliserState.OK
        self._bad_since = None
        self._full_search = True  # first match after an initial pose uses every level
        self._odom_at_scan = self._odom
        self.dynamic.reset_streaks()

    def on_odometry(self, odom_pose: Pose2D, now: float) -> None:
        """Latest odometry pose (``odom`` frame); only increments between scans are used."""
        del now  # increments are taken between scans; time is not needed
        if self._odom is not None:
            self._travel_m += self._odom.distance_to(odom_pose)
        self._odom = odom_pose

    def on_scan(self, scan: LaserScan, now: float) -> LocaliserEstimate:
        """Match one scan and return the new estimate."""
        if self._pose is None:
            self._last = LocaliserEstimate(None, LocaliserState.UNSET, 0.0, 0.0, now)
            return self._last
        cfg = self.config
        step = self._odometry_step()
        predicted = self._pose.compose(step)
        if self._state is LocaliserState.LOST:
            self._pose = predicted
            self._last = LocaliserEstimate(predicted, LocaliserState.LOST, 0.0, 0.0, now)
            return self._last

        points = self._scan_points(scan)
        impossible = 0.0
        if points.shape[0] < 10:
            pose, confidence, score, bad = predicted, 0.0, 0.0, True
        else:
            sxy, syaw = self._prior_sigma(step)
            start = None if self._full_search else self.matcher.start_level(sxy, syaw)
            result = self.matcher.match(points, predicted, start)
            correction = result.pose.relative_to(predicted)
            step_len = math.hypot(step.x, step.y)
            jump = math.hypot(correction.x, correction.y) > (
                cfg.max_jump_m + cfg.max_jump_gain * step_len
            ) or abs(correction.yaw) > cfg.max_jump_rad + cfg.max_jump_gain * abs(step.yaw)
            if jump:
                pose = predicted
                bad = True
                self._full_search = True
            else:
                # After an initial pose or a rejected match the prior is not odometry-grade:
                # take the match as it is.
                blend = cfg.odom_blend and not self._full_search
                pose = self._fuse(predicted, result, step) if blend else result.pose
                self._full_search = False
                bad = False
            score = result.score
            fine = subsample_points(points, cfg.matcher.max_points)
            confidence = self._hit_fraction(fine, pose)
            see_through = confidence >= cfg.see_through_min_confidence
            impossible = self.impossible_fraction(points, pose, see_through)
            bad = bad or confidence < cfg.lost_confidence or impossible > cfg.lost_impossible
            if not bad and cfg.map_update and confidence >= cfg.map_update_min_confidence:
                self._update_map(points, pose, now)

        if bad:
            if self._bad_since is None:
                self._bad_since = now
            if now - self._bad_since >= cfg.lost_after_s:
                logger.warning(
                    "localisation lost at t=%.2f (bad scans for %.2f s; last: confidence %.2f, "
                    "impossible beams %.2f)",
                    now,
                    now - self._bad_since,
                    confidence,
                    impossible,
                )
                self._state = LocaliserState.LOST
        else:
            self._bad_since = None
        self._pose = pose
        self._last = LocaliserEstimate(pose, self._state, confidence, score, now, impossible)
        return self._last

    # --------------------------------------------------------------- outputs

    def updated_grid(self) -> OccupancyGrid:
        """The a-priori map with the promoted static obstacles marked OCCUPIED."""
        cells = self._grid.cells.copy()
        cells[self.dynamic.promoted] = OCCUPIED
        return self._grid.with_cells(cells)

    # -------------------------------------------------------------- internals

    def _odometry_step(self) -> Pose2D:
        """Odometry increment since the previous scan, in the robot frame."""
        if self._odom is None or self._odom_at_scan is None:
            self._odom_at_scan = self._odom
            return Pose2D(0.0, 0.0, 0.0)
        step = self._odom.relative_to(self._odom_at_scan)
        self._odom_at_scan = self._odom
        return step

    def _scan_points(self, scan: LaserScan) -> FloatArray:
        """Sensor-frame end points of valid beams within ``max_range_m`` (trig cached)."""
        n = scan.ranges.size
        key = (n, scan.angle_min, scan.angle_increment)
        if key != self._trig_key:
            angles = scan.angles
            self._cos, self._sin = np.cos(angles), np.sin(angles)
            self._trig_key = key
        r = scan.ranges
        mask = (r >= scan.range_min) & (r <= min(scan.range_max, self.config.max_range_m))
        rv = r[mask].astype(np.float64)
        return np.column_stack((rv * self._cos[mask], rv * self._sin[mask]))

    def _distance_to_map(self, xs: FloatArray, ys: FloatArray) -> FloatArray:
        """Distance [m] from map-frame points to the nearest occupied cell (inf outside)."""
        g = self._grid
        col = np.floor((xs - g.origin_x) / g.resolution).astype(np.intp)
        row = np.floor((ys - g.origin_y) / g.resolution).astype(np.intp)
        inside = (row >= 0) & (row < g.height) & (col >= 0) & (col < g.width)
        out = np.full(xs.shape, np.inf)
        out[inside] = self._dist_padded[(row[inside] + 1) * (g.width + 2) + col[inside] + 1]
        return out

    def _to_map(self, points: FloatArray, pose: Pose2D) -> tuple[FloatArray, FloatArray]:
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        sx, sy = points[:, 0], points[:, 1]
        return pose.x + c * sx - s * sy, pose.y + s * sx + c * sy

    def _hit_fraction(self, points: FloatArray, pose: Pose2D) -> float:
        if points.shape[0] == 0:
            return 0.0
        xs, ys = self._to_map(points, pose)
        return float(np.mean(self._distance_to_map(xs, ys) <= self.config.hit_tolerance_m))

    def impossible_fraction(
        self, points: FloatArray, pose: Pose2D, see_through: bool = False
    ) -> float:
        """Fraction of traced beams that are impossible at ``pose`` (see `impossible_beams`),
        counting only runs of at least ``impossible_min_run`` neighbouring impossible beams.

        ``see_through``: beams that pass a wall and end on a mapped surface behind it (within
        ``see_through_landing_m``) saw through an unmapped opening and are not counted.
        """
        mask = self.impossible_beams(points, pose)
        if mask.size == 0:
            return 0.0
        if see_through and mask.any():
            pts = subsample_points(points, self.config.impossible_max_beams)
            xs, ys = self._to_map(pts[mask], pose)
            landed = self._distance_to_map(xs, ys) <= self.config.see_through_landing_m
            mask[np.flatnonzero(mask)[landed]] = False
        k = self.config.impossible_min_run
        if k > 1 and mask.any():
            mask = _long_runs(mask, k)
        return float(np.count_nonzero(mask)) / mask.size

    def impossible_beams(self, points: FloatArray, pose: Pose2D) -> npt.NDArray[np.bool_]:
        """Which beams (sensor-frame end points, laser at ``pose``) pass through the map.

        Up to ``impossible_max_beams`` beams, taken with a fixed stride in scan order, are
        sphere-traced from the laser on the distance field: a point whose cell is at distance
        ``d`` from the nearest occupied cell centre is at least ``d - √2·res`` from any occupied
        cell, so the ray advances by that (at least one cell). A ray that reaches an occupied
        cell before its measured range minus ``impossible_margin_m`` is impossible; one that
        reaches that range, leaves the map (unknown: not impossible) or runs out of steps is
        possible. The margin (6 cells at 0.05 m) covers both surface conventions (face or centre
        of a cell) and the estimate's few centimetres of error. Returns one flag per traced beam.
        """
        cfg = self.config
        pts = subsample_points(points, cfg.impossible_max_beams)
        out = np.zeros(pts.shape[0], dtype=bool)
        if pts.shape[0] == 0:
            return out
        sx, sy = pts[:, 0], pts[:, 1]
        r = np.hypot(sx, sy)
        limit = r - cfg.impossible_margin_m
        idx = np.flatnonzero(limit > 0.0)
        if idx.size == 0:
            return out
        g = self._grid
        inv = 1.0 / g.resolution
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        rs = r[idx]
        # Ray directions in cells per metre; laser position in continuous cell coordinates.
        dcol = (c * sx[idx] - s * sy[idx]) / rs * inv
        drow = (s * sx[idx] + c * sy[idx]) / rs * inv
        # +1: index into the inf-bordered field; clipping sends off-map samples to the border.
        col0 = (pose.x - g.origin_x) * inv + 1.0
        row0 = (pose.y - g.origin_y) * inv + 1.0
        limit = limit[idx]
        dist = self._dist_padded
        wp = g.width + 2
        cmax, rmax = g.width + 1, g.height + 1
        slack = math.sqrt(2.0) * g.resolution
        min_step = g.resolution
        blocked_below = 0.5 * g.resolution  # an occupied cell reads 0
        depth = cfg.impossible_depth_m

        def lookup(tt: FloatArray, dc: FloatArray, dr: FloatArray) -> FloatArray:
            # minimum/maximum in place: np.clip's wrapper costs more than the lookup itself.
            col = (col0 + tt * dc).astype(np.intp)
            row = (row0 + tt * dr).astype(np.intp)
            np.minimum(col, cmax, out=col)
            np.maximum(col, 0, out=col)
            np.minimum(row, rmax, out=row)
            np.maximum(row, 0, out=row)
            row *= wp
            row += col
            out_d: FloatArray = dist.take(row)
            return out_d

        t = np.zeros(idx.shape)
        for _ in range(cfg.impossible_max_steps):
            # Truncation (astype) equals floor for padded coordinates >= 0; negative ones
            # truncate to <= 0 and clip to the border, as floor would.
            d = lookup(t, dcol, drow)
            hit = d < blocked_below
            if depth > 0.0 and hit.any():
                # Only a ray that stays inside occupied cells for `depth` goes through the map:
                # a lone occupied cell is as likely a stray end point of the mapping run.
                for frac in (0.5, 1.0):
                    deep = lookup(t[hit] + frac * depth, dcol[hit], drow[hit]) < blocked_below
                    hit[hit] = deep
            out[idx[hit]] = True
            t += np.maximum(d - slack, min_step)
            # Done: impossible (hit), reached the limit, or left the map (d = inf).
            keep = ~hit & (t < limit)
            if not keep.all():
                t, limit, dcol, drow, idx = t[keep], limit[keep], dcol[keep], drow[keep], idx[keep]
                if t.size == 0:
                    break
        return out

    def _prior_sigma(self, step: Pose2D) -> tuple[float, float]:
        """Standard deviations [m], [rad] of the odometry prediction over ``step``."""
        cfg = self.config
        step_len = math.hypot(step.x, step.y) + 0.2 * abs(step.yaw)
        sxy = cfg.prior_sigma_m + cfg.prior_sigma_gain * step_len
        syaw = cfg.prior_sigma_rad + cfg.prior_sigma_gain * abs(step.yaw)
        return sxy, syaw

    def _fuse(self, predicted: Pose2D, result: MatchResult, step: Pose2D) -> Pose2D:
        """Information-form fusion of the match with the odometry prediction."""
        cfg = self.config
        sxy, syaw = self._prior_sigma(step)
        prior_info = np.diag([1.0 / sxy**2, 1.0 / sxy**2, 1.0 / syaw**2])
        match_info = result.hessian / cfg.match_residual_var
        diff = np.array(
            [
                result.pose.x - predicted.x,
                result.pose.y - predicted.y,
                wrap_angle(result.pose.yaw - predicted.yaw),
            ]
        )
        try:
            delta = np.linalg.solve(prior_info + match_info, match_info @ diff)
        except np.linalg.LinAlgError:
            return result.pose
        return Pose2D(predicted.x + delta[0], predicted.y + delta[1], predicted.yaw + delta[2])

    def _update_map(self, points: FloatArray, pose: Pose2D, now: float) -> None:
        cfg = self.config
        near = points[np.einsum("ij,ij->i", points, points) <= cfg.map_update_max_range_m**2]
        xs, ys = self._to_map(near, pose)
        unexplained = self._distance_to_map(xs, ys) > cfg.unexplained_m
        if not unexplained.any():
            return
        px, py = self.dynamic.update(xs[unexplained], ys[unexplained], now, self._travel_m)
        if px.size:
            logger.info("map update: %d cells became static obstacles", px.size)
            self.matcher.add_obstacles(px, py)
            self._add_distance_obstacles(px, py)

    def _add_distance_obstacles(self, xs: FloatArray, ys: FloatArray) -> None:
        g = self._grid
        dist = self._dist_padded.reshape(g.height + 2, g.width + 2)[1:-1, 1:-1]  # a view
        k = self._dist_radius
        for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
            col = math.floor((x - g.origin_x) / g.resolution)
            row = math.floor((y - g.origin_y) / g.resolution)
            r0, r1 = max(row - k, 0), min(row + k + 1, g.height)
            c0, c1 = max(col - k, 0), min(col + k + 1, g.width)
            patch = self._dist_kernel[r0 - row + k : r1 - row + k, c0 - col + k : c1 - col + k]
            np.minimum(dist[r0:r1, c0:c1], patch, out=dist[r0:r1, c0:c1])


def _long_runs(mask: npt.NDArray[np.bool_], k: int) -> npt.NDArray[np.bool_]:
    """``mask`` with only the runs of at least ``k`` consecutive True entries kept."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    starts, ends = edges[::2], edges[1::2]
    long = ends - starts >= k
    out = np.zeros_like(mask)
    for a, b in zip(starts[long].tolist(), ends[long].tolist(), strict=True):
        out[a:b] = True
    return out
