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
* **Loss detection.** A scan is *bad* if its confidence is below ``lost_confidence`` or its
  correction ``x_m ⊖ x_pred`` is implausibly large (it is then rejected). Bad scans for
  ``lost_after_s`` seconds in a row make the state ``lost``. While lost the pose follows odometry
  alone and the state stays ``lost`` until `set_initial_pose` is called.
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
        self._dist = np.ascontiguousarray(dist, dtype=np.float64).reshape(-1)
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
            bad = bad or confidence < cfg.lost_confidence
            if not bad and cfg.map_update and confidence >= cfg.map_update_min_confidence:
                self._update_map(points, pose, now)

        if bad:
            if self._bad_since is None:
                self._bad_since = now
            if now - self._bad_since >= cfg.lost_after_s:
                logger.warning(
                    "localisation lost at t=%.2f (confidence %.2f for %.2f s)",
                    now,
                    confidence,
                    now - self._bad_since,
                )
                self._state = LocaliserState.LOST
        else:
            self._bad_since = None
        self._pose = pose
        self._last = LocaliserEstimate(pose, self._state, confidence, score, now)
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
        out[inside] = self._dist[row[inside] * g.width + col[inside]]
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
        dist = self._dist.reshape(g.height, g.width)
        k = self._dist_radius
        for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
            col = math.floor((x - g.origin_x) / g.resolution)
            row = math.floor((y - g.origin_y) / g.resolution)
            r0, r1 = max(row - k, 0), min(row + k + 1, g.height)
            c0, c1 = max(col - k, 0), min(col + k + 1, g.width)
            patch = self._dist_kernel[r0 - row + k : r1 - row + k, c0 - col + k : c1 - col + k]
            np.minimum(dist[r0:r1, c0:c1], patch, out=dist[r0:r1, c0:c1])
