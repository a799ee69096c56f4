"""The odometry's scale, estimated online from matched motion (issue 12: fuse odometry along the
weak direction, and know how far to trust it there).

Wheel odometry is off by a *systematic* factor: wheel radii believed a few per cent wrong
(thesis §6.1: 8 % uncalibrated, 3 % after calibration; the realistic simulator's wheels 3 %;
the real-log replays 5 %). A Kalman filter that models that error as independent noise per
step lets it average out as the square root of the distance, which it does not: along a
featureless corridor the prediction runs ahead (or behind) by the full 3-5 % of the distance,
while the covariance claims a fraction of that. Here the filter carries the scale ``k`` as a
fourth state (true translation = ``k`` x odometry translation), as an augmented-state EKF does
for a sensor bias (Thrun, Burgard, Fox, *Probabilistic Robotics*, 2005, §7.4; robot_localization
and Cartographer's odometry calibration do the same for wheel odometry):

* **Prediction.** ``x' = x ⊕ (k sx, k sy, s_yaw)``; with ``J = ∂x'/∂k = (R(yaw) (sx, sy), 0)``
  and ``F = ∂x'/∂x`` the pose covariance gains ``F c Jᵀ + J cᵀ Fᵀ + v J Jᵀ``, where ``c`` is the
  pose-scale cross-covariance and ``v`` the scale's variance: an unknown scale makes the
  uncertainty along the travel grow *linearly* with the distance, as the error does.
* **Update.** The scan match measures the pose only, so the scale follows from the pose update
  by Gaussian conditioning (`learnt_state.LearntScalar.update`). Where the scan pins the pose along the travel (a door
  jamb, a corridor's end), the correction teaches the scale; along a featureless corridor the
  learnt scale carries the pose.

The scale is a property of the robot, not of its pose: a new initial pose keeps it (and drops
the cross-covariance). It is bounded to ``1 ± max_error``.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from robot_daemon.localisation.learnt_state import LearntScalar

FloatArray = npt.NDArray[np.float64]


class OdometryScaleConfigError(ValueError):
    """An odometry-scale parameter is out of range; the message names it."""


class OdometryScaleConfig(schema.Declared, frozen=True):
    """Prior and drift of the odometry's scale (true / odometry translation)."""

    ROOT: ClassVar[str] = "OdometryScaleConfig"
    ERROR: ClassVar[type[Exception]] = OdometryScaleConfigError
    enabled: bool = True
    # prior sigma of the scale (5 %: between calibrated and uncalibrated)
    sigma: Annotated[float, Meta(ge=1e-4, le=0.5)] = 0.05
    # the scale drifts (tyre wear, floor): sigma per sqrt(metre)
    walk_per_sqrt_m: Annotated[float, Meta(ge=0.0, le=0.1)] = 0.002
    max_error: Annotated[float, Meta(ge=0.01, le=0.5)] = 0.2  # the estimate stays within 1 ± this


class OdometryScale(LearntScalar):
    """The scale estimate ``value``, its variance ``var`` and its cross-covariance with the pose
    (`learnt_state.LearntScalar` keeps, updates and resets them)."""

    def __init__(self, config: OdometryScaleConfig | None = None) -> None:
        self.config = config or OdometryScaleConfig()
        lim = self.config.max_error
        super().__init__(1.0, self.config.sigma**2, 1.0 - lim, 1.0 + lim, 1e-10)

    def scaled(self, step: Pose2D) -> Pose2D:
        """The odometry increment with the scale applied to its translation."""
        if not self.config.enabled:
            return step
        return Pose2D(self.value * step.x, self.value * step.y, step.yaw)

    def predict(self, pose: Pose2D, step: Pose2D, scaled: Pose2D, cov: FloatArray) -> FloatArray:
        """The scale's share of the prediction: ``cov`` (the pose covariance propagated along
        ``scaled`` from ``pose``, without the scale) plus the terms of the scale's uncertainty.
        Remembers the predicted cross-covariance and variance for `update`."""
        if not self.config.enabled:
            return cov
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        k0, k1, k2 = self.cross
        v = self.var
        # F c with F = ∂x'/∂x (the identity but for the yaw column), and J = ∂x'/∂k.
        f0 = k0 + (-s * scaled.x - c * scaled.y) * k2
        f1 = k1 + (c * scaled.x - s * scaled.y) * k2
        j0, j1 = c * step.x - s * step.y, s * step.x + c * step.y
        # F c Jᵀ + J cᵀ Fᵀ + v J Jᵀ (J's yaw entry is 0).
        a00 = 2.0 * f0 * j0 + v * j0 * j0
        a01 = f0 * j1 + f1 * j0 + v * j0 * j1
        a11 = 2.0 * f1 * j1 + v * j1 * j1
        out: FloatArray = cov + np.array(
            [[a00, a01, k2 * j0], [a01, a11, k2 * j1], [k2 * j0, k2 * j1, 0.0]]
        )
        self.remember_prediction(
            (f0 + j0 * v, f1 + j1 * v, k2),
            v + self.config.walk_per_sqrt_m**2 * math.hypot(step.x, step.y),
        )
        return out
