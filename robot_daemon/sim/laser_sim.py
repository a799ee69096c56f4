"""Simulated Hokuyo UTM-30LX: sphere tracing on the world's distance transform.

Sensor (thesis §4.1.5; Hokuyo UTM-30LX datasheet): 1081 beams over 270 degrees (0.25 degree
steps), 0.1-30 m, 40 Hz, mounted ``mount_x`` ahead of base_link. Ranges get Gaussian noise
(sigma 0.03 m by default, the datasheet's +-30 mm accuracy at 0.1-10 m).

``LaserConfig.realistic()`` is the error model of a real UTM-30LX as the simulated world uses it
(issue 12; Pomerleau et al., "Noise characterization of depth sensors for surface inspections",
2012, and Okubo et al., "Characterization of the Hokuyo URG-04LX", 2009, for the effects):

* per-beam noise ``N(0, noise_sigma)`` (10 mm) plus a slowly varying bias common to the scan, an
  Ornstein-Uhlenbeck process ``b(t + dt) = b e^{-dt/tau} + bias_sigma sqrt(1 - e^{-2 dt/tau}) n``
  (stationary std ``bias_sigma``, time constant ``bias_tau``: the sensor's temperature drift);
* dropouts: a beam returns nothing (+inf, REP-117) with probability
  ``dropout_probability + far_dropout_per_m * range`` (dark or grazing surfaces far away);
* mixed pixels: where neighbouring beams differ by more than ``mixed_pixel_jump`` the farther one
  returns, with probability ``mixed_pixel_probability``, a range uniformly between the two (the
  spot straddles the edge and the sensor averages the echoes);
* glass (``World.glass``): a beam meeting a pane within ``glass_return_angle`` of its normal is
  reflected back and returns the pane's range; any other beam passes through and returns what is
  behind the pane.

The per-beam passes are compiled (`robot_daemon.jit`): walls in `sphere_tracing`, people and
panes in `analytic_rays`, the range errors in `range_errors` (the random draws stay here).

No-return convention (REP-117): a beam with nothing within ``range_max`` reports ``+inf``; a
return closer than ``range_min`` reports ``-inf``. Consumers use ``LaserScan.valid()``.

Ray casting (sphere tracing, Hart, "Sphere tracing", The Visual Computer 12(10), 1996; compiled
in `sphere_tracing`). Each beam advances, in grid-cell units, by the safe step stored per cell
by ``World`` (the distance to the nearest blocked cell minus sqrt(2), or a fine step of half a
cell when that is smaller; a beam that clips a blocked cell's corner for less than that step may
pass it, a map-discretisation error of the same order as the cells themselves, tested against
an exact grid traversal):

    t_{k+1} = t_k + step(cell(o + t_k d)),   stop when cell(o + t_k d) is blocked or t_k > r_max.

The hit is then refined by re-sampling the last fine step at a tenth of a cell, so a wall range
is exact to about 0.005 m plus the cell discretisation of the map itself. People are circles
intersected analytically:

    t = (d . (c - o)) - sqrt((d . (c - o))^2 - |c - o|^2 + r^2).
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import (
    UTM30LX_ANGLE_INCREMENT,
    UTM30LX_ANGLE_MIN,
    UTM30LX_BEAMS,
    UTM30LX_RANGE_MAX,
    UTM30LX_RANGE_MIN,
    UTM30LX_SCAN_TIME,
    LaserScan,
)
from robot_daemon.sim.analytic_rays import circle_ranges, pane_ranges
from robot_daemon.sim.range_errors import apply_errors, jump_pairs, mix_pairs
from robot_daemon.sim.sphere_tracing import wall_ranges
from robot_daemon.sim.world import World

FloatArray = npt.NDArray[np.float64]
_NONE = np.empty(0)  # no draws


class LaserConfigError(ValueError):
    """A laser parameter is out of range; the message names the field."""


Metres = Annotated[float, Meta(ge=0.0, le=1000.0, extra={"unit": "m"})]
Probability = Annotated[float, Meta(ge=0.0, le=1.0)]


class LaserConfig(schema.Declared, frozen=True):
    """Beam geometry, noise and mounting of the simulated scanner."""

    ROOT: ClassVar[str] = "LaserConfig"
    ERROR: ClassVar[type[Exception]] = LaserConfigError
    beams: Annotated[int, Meta(ge=1)] = UTM30LX_BEAMS
    angle_min: schema.Finite = UTM30LX_ANGLE_MIN  # [rad]
    angle_increment: Annotated[float, Meta(gt=0.0, le=schema.FINITE)] = UTM30LX_ANGLE_INCREMENT
    range_min: Metres = UTM30LX_RANGE_MIN
    range_max: Metres = UTM30LX_RANGE_MAX
    scan_period: Annotated[float, Meta(gt=0.0, le=schema.FINITE)] = UTM30LX_SCAN_TIME  # [s] 40 Hz
    noise_sigma: Annotated[float, Meta(ge=0.0, le=schema.FINITE)] = 0.03  # [m]
    mount_x: schema.Finite = 0.2  # [m] ahead of base_link
    mount_y: schema.Finite = 0.0  # [m]
    mount_yaw: schema.Finite = 0.0  # [rad]
    # [m] stationary std of the slowly varying range bias
    bias_sigma: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.0
    bias_tau: Annotated[float, Meta(gt=0.0, le=schema.FINITE)] = 20.0  # [s] its time constant
    dropout_probability: Probability = 0.0  # per beam: no return (+inf)
    far_dropout_per_m: Probability = 0.0  # [1/m] extra dropout probability per metre of range
    mixed_pixel_probability: Probability = 0.0  # at a range discontinuity
    mixed_pixel_jump: Annotated[float, Meta(gt=0.0, le=100.0)] = 0.3  # [m] a discontinuity
    # [rad] panes return beams this close to their normal
    glass_return_angle: Annotated[float, Meta(ge=0.0, le=math.pi / 2)] = 0.17

    def check(self) -> None:
        if not self.range_min < self.range_max:
            raise LaserConfigError("LaserConfig needs 0 <= range_min < range_max <= 1000 m")

    @classmethod
    def realistic(cls) -> LaserConfig:
        """A real UTM-30LX (see the module docstring): 10 mm noise, 10 mm drifting bias."""
        return cls(
            noise_sigma=0.01,
            bias_sigma=0.01,
            bias_tau=20.0,
            dropout_probability=0.003,
            far_dropout_per_m=0.002,
            mixed_pixel_probability=0.5,
        )

    @property
    def mount(self) -> Pose2D:
        """Pose of the laser frame in base_link."""
        return Pose2D(self.mount_x, self.mount_y, self.mount_yaw)

    def beam_angles(self) -> FloatArray:
        """Beam angles in the laser frame [rad]."""
        return self.angle_min + self.angle_increment * np.arange(self.beams, dtype=np.float64)


class RayCaster:
    """Casts many rays at once against a ``World``'s walls (and optionally people circles)."""

    def __init__(self, world: World) -> None:
        self.world = world
        # The last `cast` call's walls: a robot standing still (a tour stop, a rotation's
        # end) casts the same beams from the same point again, which the walls answer alike.
        self._last_walls: tuple[tuple[float, float, float, int], FloatArray, FloatArray] | None
        self._last_walls = None

    def cast_walls(
        self,
        origin_x: float,
        origin_y: float,
        angles: FloatArray,
        max_range: float,
        trig: tuple[FloatArray, FloatArray] | None = None,
    ) -> FloatArray:
        """Distance [m] along each world-frame angle to the first blocked cell; inf if none
        (sphere tracing, `sphere_tracing.wall_ranges`).

        ``trig``: ``(cos(angles), sin(angles))`` if the caller has them.
        """
        w = self.world
        cos, sin = _contiguous_trig(angles, trig)
        u0, v0 = (float(c) for c in w.to_padded_cells(origin_x, origin_y))
        if not (0 <= u0 < w.padded_width and 0 <= v0 < w.padded_height):
            return np.zeros(angles.size)
        ranges = np.empty(angles.size)
        resolution, max_range = float(w.resolution), float(max_range)
        wall_ranges(  # one layout and dtype, so one compiled specialisation
            w.ray_step_flat,
            int(w.padded_width),
            u0,
            v0,
            cos,
            sin,
            max_range / resolution,
            resolution,
            max_range,
            ranges,
        )
        return ranges

    @staticmethod
    def cast_circles(
        origin_x: float,
        origin_y: float,
        angles: FloatArray,
        circles: FloatArray,
        trig: tuple[FloatArray, FloatArray] | None = None,
    ) -> tuple[FloatArray, npt.NDArray[np.intp]]:
        """Range [m] to the nearest circle along each angle (inf if none) and its index (-1)
        (`analytic_rays.circle_ranges`). ``trig``: ``(cos(angles), sin(angles))`` if the caller
        has them."""
        n = angles.size
        ranges, nearest = np.empty(n), np.empty(n, dtype=np.intp)
        if circles.size == 0:
            ranges[:], nearest[:] = np.inf, -1
            return ranges, nearest
        cos, sin = _contiguous_trig(angles, trig)
        circles = np.ascontiguousarray(circles, dtype=np.float64)
        circle_ranges(float(origin_x), float(origin_y), cos, sin, circles, ranges, nearest)
        return ranges, nearest

    def cast_glass(
        self,
        origin_x: float,
        origin_y: float,
        angles: FloatArray,
        return_angle: float,
        trig: tuple[FloatArray, FloatArray] | None = None,
    ) -> FloatArray:
        """Range [m] to the first glass pane that reflects each beam back (inf if none): a
        beam within ``return_angle`` of the normal of the face it enters
        (`analytic_rays.pane_ranges`). ``trig``: ``(cos(angles), sin(angles))`` if the caller
        has them."""
        ranges = np.empty(angles.size)
        if not self.world.glass:
            ranges[:] = np.inf
            return ranges
        cos, sin = _contiguous_trig(angles, trig)
        threshold = math.cos(float(return_angle))
        panes = np.array(self.world.glass, dtype=np.float64)  # rows x0, y0, x1, y1
        pane_ranges(float(origin_x), float(origin_y), cos, sin, panes, threshold, ranges)
        return ranges

    def cast(
        self,
        origin_x: float,
        origin_y: float,
        angles: FloatArray,
        max_range: float,
        circles: FloatArray | None = None,
        glass_return_angle: float = 0.0,
    ) -> FloatArray:
        """Noise-free range [m] to walls or people along each world-frame angle; inf if none.

        Glass panes (``World.glass``) return only beams within ``glass_return_angle`` of their
        normal; other beams see through them.
        """
        trig = (np.cos(angles), np.sin(angles))  # once for walls, panes and people
        key = (origin_x, origin_y, max_range, self.world.version)
        last = self._last_walls
        if last is not None and last[0] == key and np.array_equal(last[1], angles):
            ranges = last[2].copy()
        else:
            ranges = self.cast_walls(origin_x, origin_y, angles, max_range, trig)
            self._last_walls = (key, angles.copy(), ranges.copy())
        if self.world.glass:
            pane = self.cast_glass(origin_x, origin_y, angles, glass_return_angle, trig)
            ranges = np.minimum(ranges, np.where(pane <= max_range, pane, np.inf))
        if circles is not None and circles.size:
            people, _ = self.cast_circles(origin_x, origin_y, angles, circles, trig)
            ranges = np.minimum(ranges, np.where(people <= max_range, people, np.inf))
        return ranges


class LaserSim:
    """Produces ``LaserScan`` messages for a robot pose; noise from a seeded Generator."""

    def __init__(
        self,
        world: World,
        config: LaserConfig | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.config = config or LaserConfig()
        self.caster = RayCaster(world)
        self._rng = rng if rng is not None else np.random.default_rng(0)
        self._beam_angles = self.config.beam_angles()
        self._bias = 0.0  # [m] current slowly varying range bias
        self._bias_stamp: float | None = None

    def _advance_bias(self, stamp: float) -> float:
        """The Ornstein-Uhlenbeck range bias at ``stamp`` [s] (see the module docstring)."""
        c = self.config
        if c.bias_sigma <= 0.0:
            return 0.0
        if self._bias_stamp is None:
            self._bias = float(self._rng.normal(0.0, c.bias_sigma))
        else:
            decay = math.exp(-max(stamp - self._bias_stamp, 0.0) / c.bias_tau)
            kick = c.bias_sigma * math.sqrt(max(1.0 - decay * decay, 0.0))
            self._bias = self._bias * decay + kick * float(self._rng.normal())
        self._bias_stamp = stamp
        return self._bias

    def _mix_pixels(self, ranges: FloatArray) -> None:
        """Farther beam of each discontinuous neighbour pair -> a range between the two."""
        c = self.config
        pairs = np.empty(ranges.size, dtype=np.intp)
        count = jump_pairs(ranges, float(c.mixed_pixel_jump), pairs)
        if count == 0:
            return
        pairs = pairs[:count]
        chosen = pairs[self._rng.random(count) < c.mixed_pixel_probability]
        if chosen.size == 0:
            return
        mix_pairs(ranges, chosen, self._rng.random(chosen.size))

    def scan(
        self, robot_pose: Pose2D, stamp: float, circles: FloatArray | None = None
    ) -> LaserScan:
        """One scan from the laser mounted on a robot at ``robot_pose`` (true, map frame)."""
        c = self.config
        sensor = robot_pose.compose(c.mount)  # the laser frame in the world
        true = self.caster.cast(
            sensor.x,
            sensor.y,
            self._beam_angles + sensor.yaw,
            c.range_max,
            circles,
            c.glass_return_angle,
        )
        ranges = true.copy()
        if c.mixed_pixel_probability > 0:
            self._mix_pixels(ranges)
        # The random draws of the error model, in its order (`range_errors`), then its passes.
        finite = int(np.count_nonzero(np.isfinite(ranges)))
        noise = self._rng.normal(0.0, c.noise_sigma, finite) if c.noise_sigma > 0 else _NONE
        bias = self._advance_bias(stamp) if c.bias_sigma > 0 else 0.0
        dropout = c.dropout_probability > 0 or c.far_dropout_per_m > 0
        uniform = self._rng.random(ranges.size) if dropout else _NONE
        ranges32 = np.empty(ranges.size, dtype=np.float32)
        apply_errors(  # floats as floats: one compiled specialisation
            ranges,
            noise,
            float(bias),
            dropout,
            float(c.dropout_probability),
            float(c.far_dropout_per_m),
            uniform,
            float(c.range_min),
            float(c.range_max),
            ranges32,
        )
        return LaserScan(
            stamp=stamp,
            angle_min=c.angle_min,
            angle_increment=c.angle_increment,
            range_min=c.range_min,
            range_max=c.range_max,
            ranges=ranges32,
        )


def _contiguous_trig(
    angles: FloatArray, trig: tuple[FloatArray, FloatArray] | None
) -> tuple[FloatArray, FloatArray]:
    """``(cos(angles), sin(angles))`` as C-contiguous float64 (one compiled specialisation)."""
    cos, sin = trig if trig is not None else (np.cos(angles), np.sin(angles))
    return np.ascontiguousarray(cos, dtype=np.float64), np.ascontiguousarray(sin, dtype=np.float64)
