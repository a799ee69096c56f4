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
  by Gaussian conditioning: with ``A = cᵀ P⁻¹`` (``P`` the predicted pose covariance),
  ``k += A Δx``, ``v ← v - A c + A P⁺ Aᵀ``, ``c ← P⁺ Aᵀ`` (``Δx``, ``P⁺``: the pose's
  correction and posterior covariance). Where the scan pins the pose along the travel (a door
  jamb, a corridor's end), the correction teaches the scale; along a featureless corridor the
  learnt scale carries the pose.

The scale is a property of the robot, not of its pose: a new initial pose keeps it (and drops
the cross-covariance). It is bounded to ``1 ± max_error``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D

FloatArray = npt.NDArray[np.float64]


class OdometryScaleConfigError(ValueError):
    """An odometry-scale parameter is out of range; the message names it."""


@dataclass(frozen=True)
class OdometryScaleConfig:
    """Prior and drift of the odometry's scale (true / odometry translation)."""

    enabled: bool = True
    sigma: float = 0.05  # prior sigma of the scale (5 %: between calibrated and uncalibrated)
    walk_per_sqrt_m: float = 0.002  # the scale drifts (tyre wear, floor): sigma per sqrt(metre)
    max_error: float = 0.2  # the estimate stays within 1 ± this

    def __post_init__(self) -> None:
        for name, value, low, high in (
            ("sigma", self.sigma, 1e-4, 0.5),
            ("walk_per_sqrt_m", self.walk_per_sqrt_m, 0.0, 0.1),
            ("max_error", self.max_error, 0.01, 0.5),
        ):
            if not (math.isfinite(value) and low <= value <= high):
                raise OdometryScaleConfigError(
                    f"OdometryScaleConfig.{name} must be in [{low}, {high}], got {value}"
                )


class OdometryScale:
    """The scale estimate ``value``, its variance ``var`` and its cross-covariance with the pose."""

    def __init__(self, config: OdometryScaleConfig | None = None) -> None:
        self.config = config or OdometryScaleConfig()
        self.value = 1.0
        self.var = self.config.sigma**2
        self.cross = (0.0, 0.0, 0.0)  # cov(pose (x, y, yaw), scale)
        # (cross, var) after `predict`, until `update` or `keep_prediction`
        self._pred: tuple[tuple[float, float, float], float] | None = None

    def reset_cross(self) -> None:
        """A new pose was set: it is independent of the scale learnt so far."""
        self.cross = (0.0, 0.0, 0.0)
        self._pred = None

    def scaled(self, step: Pose2D) -> Pose2D:
        """The odometry increment with the scale applied to its translation."""
        if not self.config.enabled:
            return step
        return Pose2D(self.value * step.x, self.value * step.y, step.yaw)

    def predict(self, pose: Pose2D, step: Pose2D, scaled: Pose2D, cov: FloatArray) -> FloatArray:
        """The scale's share of the prediction: ``cov`` (the pose covariance propagated along
        ``scaled`` from ``pose``, without the scale) plus the terms of the scale's uncertainty.
        Remembers the predicted cross-covariance and variance for `update`. (Plain floats: a
        few 3-vectors, cheaper than numpy's per-call overhead at 10-40 scans a second.)"""
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
        cross = (f0 + j0 * v, f1 + j1 * v, k2)
        var = v + self.config.walk_per_sqrt_m**2 * math.hypot(step.x, step.y)
        self._pred = (cross, var)
        return out

    def keep_prediction(self) -> None:
        """No update this scan (match rejected, lost): the prediction stands."""
        if self._pred is not None:
            self.cross, self.var = self._pred
        self._pred = None

    def update(self, cov_pred: FloatArray, cov_post: FloatArray, correction: FloatArray) -> None:
        """Condition the scale on the pose update ``correction`` = posterior - prediction
        (x, y, yaw) with the pose covariances before and after."""
        if self._pred is None:
            return
        cross, var = self._pred
        self._pred = None
        a = _solve_spd3(cov_pred.tolist(), cross)  # P⁻¹ c (P symmetric): Aᵀ
        if a is None:
            self.cross, self.var = cross, var
            return
        post = cov_post.tolist()
        pa = tuple(sum(post[r][q] * a[q] for q in range(3)) for r in range(3))  # P⁺ Aᵀ
        gain = sum(a[q] * float(correction[q]) for q in range(3))
        lim = self.config.max_error
        self.value = min(max(self.value + gain, 1.0 - lim), 1.0 + lim)
        reduce = sum(a[q] * cross[q] for q in range(3)) - sum(a[q] * pa[q] for q in range(3))
        self.var = max(var - reduce, 1e-10)
        self.cross = (pa[0], pa[1], pa[2])


def _solve_spd3(
    m: list[list[float]], b: tuple[float, float, float]
) -> tuple[float, float, float] | None:
    """``m⁻¹ b`` for a symmetric 3x3 ``m`` (Cramer's rule); None if ``m`` is singular."""
    (p, q, r), (_, t, u), (_, _, w) = m
    c0, c1, c2 = t * w - u * u, r * u - q * w, q * u - r * t
    det = p * c0 + q * c1 + r * c2
    if not abs(det) > 1e-300:
        return None
    d11, d12, d22 = p * w - r * r, q * r - p * u, p * t - q * q
    return (
        (b[0] * c0 + b[1] * c1 + b[2] * c2) / det,
        (b[0] * c1 + b[1] * d11 + b[2] * d12) / det,
        (b[0] * c2 + b[1] * d12 + b[2] * d22) / det,
    )
