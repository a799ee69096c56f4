"""How far a *perfect* localiser would be from the truth: the map's own error at a place.

METRICS ONLY: this module reads the simulator's ground truth and never feeds the robot.

The realistic world (`robot_daemon.sim.realistic_world`) is not the map: rooms are moved by a
few centimetres (σ 3.5 cm per axis), furniture is added or moved, panes let the laser through.
Where the laser sees only a moved room, the pose that best fits the scan *on the map* is off
the truth by about that room's offset, whatever the localiser does. A localisation error in
the world frame (``loc_rms_m``, the tour's headline) therefore mixes two things:

* the **map echo** ``e_map = ref ⊖ truth``: the pose a perfect matcher gives for a noise-free,
  people-free scan taken from the truth, matched against the map from the truth (the one wall
  model of the robot, the robot's matcher, the robot's map with its unknown edges as
  surfaces), and
* the **localiser's own error** ``e_own = estimate ⊖ ref``: what noise, people, odometry,
  the filter and the matcher's local optima add on top.

``|e_world| <= |e_map| + |e_own|``; the figures are reported side by side
(`runner.Metrics`), today's world-frame figure unchanged. The reference is computed at a
reduced rate (it costs a ray cast and a match); its CPU time is kept out of the real-time
factors, which measure the robot's stack.
"""

from __future__ import annotations

import math

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation.localiser import LocaliserConfig, surfaces_with_unknown_edges
from robot_daemon.localisation.scan_matcher import ScanMatcher, ScanMatcherConfig
from robot_daemon.sim.laser_sim import LaserConfig, RayCaster
from robot_daemon.sim.world import World

NEAR_M = 0.3  # [m] the perfect matcher's fit is searched this close to the truth (issue 12's
# silent-failure bound: a localiser farther off is wrong, whatever the map)


class MapEcho:
    """The perfect matcher's pose for a robot standing at a true pose (see the module doc)."""

    def __init__(
        self,
        grid: OccupancyGrid,
        world: World,
        laser: LaserConfig,
        localiser: LocaliserConfig,
        robot_mount: Pose2D,
    ) -> None:
        """``grid``: the robot's a-priori map; ``world``: the simulator's building (walls,
        furniture, glass; people are left out); ``laser``: the simulated scanner (geometry and
        mounting; its noise is not applied); ``robot_mount``: the laser in base_link as the
        robot believes it (the localiser's frame)."""
        if localiser.unknown_edges_are_surfaces:
            grid = surfaces_with_unknown_edges(grid)
        self._grid = grid
        self._matcher = ScanMatcher(grid, localiser.matcher)
        self._caster = RayCaster(world)
        self._laser = laser
        self._angles = laser.beam_angles()
        self._cos, self._sin = np.cos(self._angles), np.sin(self._angles)
        self._max_range = min(laser.range_max, localiser.max_range_m)
        self._mount = robot_mount
        self._mount_inv = robot_mount.inverse()

    def follow(self, matcher: ScanMatcherConfig) -> None:
        """Match with the robot's matcher as it is now: a localiser that learns its map's wall
        model (`robot_daemon.localisation.wall_model`) switches it once."""
        if matcher != self._matcher.config:
            self._matcher = ScanMatcher(self._grid, matcher)

    def noise_free_points(self, truth: Pose2D) -> np.ndarray:
        """Sensor-frame end points of a noise-free, people-free scan from base_link ``truth``."""
        sensor = truth.compose(self._laser.mount)
        ranges = self._caster.cast(
            sensor.x,
            sensor.y,
            self._angles + sensor.yaw,
            self._laser.range_max,
            None,
            self._laser.glass_return_angle,
        )
        ok = np.isfinite(ranges) & (ranges >= self._laser.range_min)
        ok &= ranges <= self._max_range
        r = ranges[ok]
        return np.column_stack((r * self._cos[ok], r * self._sin[ok]))

    def reference(self, truth: Pose2D) -> Pose2D:
        """base_link pose a perfect matcher gives on the map for a robot truly at ``truth``:
        the best fit of the noise-free scan near the truth. Matched from the truth starting on
        the finest level and on the next (the finest alone may stop short of an optimum 5-10 cm
        away); the best score among the results within ``NEAR_M`` of the truth wins (a coarse
        start may slide a corridor's length to a look-alike: not the map's error at this
        place, a matcher's), else the finest level's."""
        points = self.noise_free_points(truth)
        start = truth.compose(self._mount)
        if points.shape[0] < 10:
            return truth
        best = self._matcher.match(points, start, 0)
        for level in range(1, min(2, len(self._matcher.levels))):
            result = self._matcher.match(points, start, level)
            near = result.pose.distance_to(start) <= NEAR_M
            if near and result.score > best.score:
                best = result
        return best.pose.compose(self._mount_inv)


def pose_error(a: Pose2D, b: Pose2D) -> np.ndarray:
    """``a - b`` as (x [m], y [m], yaw [rad]) in the map frame, the yaw wrapped."""
    dyaw = math.remainder(a.yaw - b.yaw, 2.0 * math.pi)
    return np.array([a.x - b.x, a.y - b.y, dyaw])


def nees(error: np.ndarray, cov: np.ndarray) -> float:
    """Normalised estimation error squared ``eᵀ P⁻¹ e`` (nan if ``P`` is not invertible).

    Over many samples its mean is the number of degrees of freedom when ``P`` is honest (a
    chi-square variable): above it, the covariance is too confident.
    """
    try:
        return float(error @ np.linalg.solve(cov, error))
    except np.linalg.LinAlgError:
        return math.nan
