"""Wheel-encoder odometry with systematic (calibration) error and random noise.

Model. The RoboteQ controller closes its speed loop on the encoders using the *believed* wheel
radii and track width (thesis §4.1.6/4.1.8: the Raspberry Pi turns encoder counts into odometry).
If the believed values are wrong, the encoders report exactly what was commanded while the real
robot moves faster or slower. Thesis §6.1, Table 6.1, measured this: uncalibrated, the robot
covered the 26 m corridor and the 2 pi turns about 8 % faster than commanded (7.7-8.7 %);
after calibration, Table 6.2, about 3 % slower (2.5-3.6 %). We parametrise it as Borenstein &
Feng's UMBmark systematic errors (IEEE T-RA 12(6), 1996):

    wheel_scale_left/right = measured arc / true arc  (= believed radius / true radius)
    track_scale            = believed track / true track

so the controller, commanding rim speeds ``v_l, v_r`` with the believed track b, makes the wheels
really turn at ``v_l / s_l, v_r / s_r`` on a track ``b / track_scale`` (``true_body_velocity``).
The odometry then integrates the measured arcs ``s * arc_true + noise`` with the believed track
(exact arc per update). Noise is zero-mean Gaussian with variance proportional to the distance
rolled (``noise_per_sqrt_m**2 * |arc|`` per wheel), drawn from a seeded ``numpy.random.Generator``.

Wheel slip on turns (``turn_slip``): in a turn the tyres scrub, so the body turns less than the
wheels' arcs say. The body's yaw rate is ``omega_wheels * (1 - s)`` with
``s = turn_slip * |omega| / (|omega| + 0.3 rad/s) * (1 + 0.5 n)``, ``n ~ N(0, 1)`` per update
(clipped to [0, 2 turn_slip]); the encoders still report the wheels' arcs.

Frames (REP-105): the result is the pose of ``base_link`` in ``odom``, which drifts without
bound and never jumps; the ``map`` frame is the simulator's ground truth and is never exposed
through this module.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from robot_daemon.sim.diff_drive import body_velocity, integrate_arc, wheel_speeds


class OdometryConfigError(ValueError):
    """An odometry error parameter is out of range; the message names the field."""


Scale = Annotated[float, Meta(ge=0.5, le=2.0)]
MODELS = ("calibrated", "perfect", "realistic", "uncalibrated")


class OdometryErrorModel(schema.Declared, frozen=True):
    """Systematic scale errors (measured / true, 1.0 = perfect) and random noise of the encoders."""

    ROOT: ClassVar[str] = "OdometryErrorModel"
    ERROR: ClassVar[type[Exception]] = OdometryConfigError
    wheel_scale_left: Scale = 1.0
    wheel_scale_right: Scale = 1.0
    track_scale: Scale = 1.0
    # [m / sqrt(m)] per-wheel std after rolling 1 m
    noise_per_sqrt_m: Annotated[float, Meta(ge=0.0, le=0.1, extra={"unit": "m/sqrt(m)"})] = 0.0
    # fraction of the wheels' rotation lost to scrubbing in turns
    turn_slip: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.0

    @classmethod
    def named(cls, name: str) -> OdometryErrorModel:
        """The model called ``name`` (one of `MODELS`: the constructors below)."""
        if name not in MODELS:
            raise OdometryConfigError(f"odometry model must be one of {list(MODELS)}, got {name!r}")
        model: OdometryErrorModel = getattr(cls, name)()
        return model

    @classmethod
    def perfect(cls) -> OdometryErrorModel:
        """No systematic error and no noise: odometry equals the truth."""
        return cls()

    @classmethod
    def uncalibrated(cls, noise_per_sqrt_m: float = 0.002) -> OdometryErrorModel:
        """Thesis Table 6.1: the robot moves ~8 % faster than commanded and odometry reports."""
        return cls(0.9225, 0.9235, 1.0, noise_per_sqrt_m)

    @classmethod
    def calibrated(cls, noise_per_sqrt_m: float = 0.002) -> OdometryErrorModel:
        """Thesis Table 6.2: after calibration the robot moves ~3 % slower than commanded."""
        return cls(1.0295, 1.0305, 1.0, noise_per_sqrt_m)

    @classmethod
    def realistic(cls, noise_per_sqrt_m: float = 0.003) -> OdometryErrorModel:
        """The calibrated robot as it really is: wheels 0.5 % unequal, the track 1.5 % off
        (believed / true), 3 % slip in turns."""
        return cls(1.0275, 1.0325, 1.015, noise_per_sqrt_m, turn_slip=0.03)

    @property
    def mean_wheel_scale(self) -> float:
        """Average measured/true wheel scale."""
        return 0.5 * (self.wheel_scale_left + self.wheel_scale_right)


def true_body_velocity(
    model: OdometryErrorModel, track_width: float, linear: float, angular: float
) -> tuple[float, float]:
    """The real (linear, angular) of a robot whose encoders track the command (linear, angular).

    ``v_l, v_r = wheel_speeds(linear, angular, b)``; true rims ``v_l / s_l``, ``v_r / s_r`` on the
    true track ``b / track_scale``.
    """
    v_l, v_r = wheel_speeds(linear, angular, track_width)
    return body_velocity(
        v_l / model.wheel_scale_left,
        v_r / model.wheel_scale_right,
        track_width / model.track_scale,
    )


def true_track_width(model: OdometryErrorModel, track_width: float) -> float:
    """The real track width [m] given the believed one."""
    return track_width / model.track_scale


class WheelOdometry:
    """Integrates measured wheel arcs into the ``odom`` pose of ``base_link``."""

    def __init__(
        self,
        model: OdometryErrorModel,
        track_width: float,
        rng: np.random.Generator,
        start: Pose2D | None = None,
    ) -> None:
        if not (math.isfinite(track_width) and track_width > 0):
            raise OdometryConfigError(f"track_width must be > 0, got {track_width!r}")
        self.model = model
        self.track_width = track_width
        self._rng = rng
        self._pose = start or Pose2D(0.0, 0.0, 0.0)
        self._linear = 0.0
        self._angular = 0.0
        self.distance = 0.0  # [m] path length as measured by the odometry

    @property
    def pose(self) -> Pose2D:
        """Current pose of base_link in odom."""
        return self._pose

    @property
    def velocity(self) -> tuple[float, float]:
        """(linear [m/s], angular [rad/s]) measured over the last update."""
        return self._linear, self._angular

    def slip_factor(self, angular: float) -> float:
        """Body yaw rate / wheels' yaw rate for a turn at ``angular`` [rad/s] (1 = no slip)."""
        slip = self.model.turn_slip
        if slip <= 0.0 or angular == 0.0:
            return 1.0
        mean = slip * abs(angular) / (abs(angular) + 0.3)
        s = mean * (1.0 + 0.5 * float(self._rng.normal()))
        return 1.0 - min(max(s, 0.0), 2.0 * slip)

    def measure(self, true_left: float, true_right: float) -> tuple[float, float]:
        """Measured wheel arcs [m] for true arcs [m]: scale error plus distance-dependent noise."""
        m = self.model
        left = true_left * m.wheel_scale_left
        right = true_right * m.wheel_scale_right
        if m.noise_per_sqrt_m > 0.0 and (true_left != 0.0 or true_right != 0.0):
            sig = m.noise_per_sqrt_m * np.sqrt(np.abs([true_left, true_right]))
            noise = self._rng.normal(0.0, 1.0, 2) * sig
            left += float(noise[0])
            right += float(noise[1])
        return left, right

    def update(self, true_left: float, true_right: float, dt: float) -> Pose2D:
        """Integrate one encoder period: true wheel arcs [m] rolled during dt [s]."""
        left, right = self.measure(true_left, true_right)
        linear_arc, dtheta = body_velocity(left, right, self.track_width)
        self._pose = integrate_arc(self._pose, linear_arc, dtheta, 1.0)
        self.distance += abs(linear_arc)
        if dt > 0:
            self._linear, self._angular = linear_arc / dt, dtheta / dt
        return self._pose
