"""One learnt scalar of the odometry carried beside the pose filter (issue 12; issue 13's D2).

The odometry's scale (`odometry_scale`) and its heading drift (`odometry_yaw_bias`) are both
an augmented-state EKF's fourth state (Thrun, Burgard, Fox, *Probabilistic Robotics*, 2005,
§7.4): a value ``k``, its variance ``v`` and its cross-covariance ``c`` with the pose (x, y,
yaw). They differ only in how the prediction moves ``c`` and ``v`` (which component of the
motion the scalar drives); the bookkeeping around it is the same and lives here:

* `remember_prediction` stores the predicted ``(c, v)`` after a subclass's ``predict``;
* `keep_prediction` makes it the state when no scan updates the pose (match rejected, lost);
* `update` conditions the scalar on the pose update. The scan match measures the pose only, so
  with ``A = cᵀ P⁻¹`` (``P`` the predicted pose covariance), ``k += A Δx``,
  ``v ← v - A c + A P⁺ Aᵀ``, ``c ← P⁺ Aᵀ`` (``Δx``, ``P⁺``: the pose's correction and
  posterior covariance), ``k`` kept within ``[low, high]``;
* `reset_cross`: a new pose was set, independent of what was learnt (the scalar is a property
  of the robot, not of its pose, and is kept).

Plain floats throughout: a few 3-vectors, cheaper than numpy's per-call overhead at 10-40
scans a second.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

Vec3 = tuple[float, float, float]


class LearntScalar:
    """A scalar state ``value`` with variance ``var`` and cross-covariance ``cross`` with the
    pose (x, y, yaw), learnt from the pose filter's updates; kept within ``[low, high]``, its
    variance at least ``var_floor``."""

    def __init__(self, value: float, var: float, low: float, high: float, var_floor: float) -> None:
        self.value = value
        self.var = var
        self.cross: Vec3 = (0.0, 0.0, 0.0)  # cov(pose (x, y, yaw), value)
        self._low, self._high, self._var_floor = low, high, var_floor
        # (cross, var) after the subclass's prediction, until `update` or `keep_prediction`
        self._pred: tuple[Vec3, float] | None = None

    def reset_cross(self) -> None:
        """A new pose was set: it is independent of the value learnt so far."""
        self.cross = (0.0, 0.0, 0.0)
        self._pred = None

    def remember_prediction(self, cross: Vec3, var: float) -> None:
        """The predicted cross-covariance and variance, for `update` or `keep_prediction`."""
        self._pred = (cross, var)

    def keep_prediction(self) -> None:
        """No update this scan (match rejected, lost): the prediction stands."""
        if self._pred is not None:
            self.cross, self.var = self._pred
        self._pred = None

    def update(self, cov_pred: FloatArray, cov_post: FloatArray, correction: FloatArray) -> None:
        """Condition the value on the pose update ``correction`` = posterior - prediction
        (x, y, yaw) with the pose covariances before and after."""
        if self._pred is None:
            return
        cross, var = self._pred
        self._pred = None
        a = solve_spd3(cov_pred.tolist(), cross)  # P⁻¹ c (P symmetric): Aᵀ
        if a is None:
            self.cross, self.var = cross, var
            return
        post = cov_post.tolist()
        pa = tuple(sum(post[r][q] * a[q] for q in range(3)) for r in range(3))  # P⁺ Aᵀ
        gain = sum(a[q] * float(correction[q]) for q in range(3))
        self.value = min(max(self.value + gain, self._low), self._high)
        reduce = sum(a[q] * cross[q] for q in range(3)) - sum(a[q] * pa[q] for q in range(3))
        self.var = max(var - reduce, self._var_floor)
        self.cross = (pa[0], pa[1], pa[2])


def solve_spd3(m: list[list[float]], b: Vec3) -> Vec3 | None:
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
