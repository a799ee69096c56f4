"""Planar geometry in REP-103 conventions: x forward, y left, yaw counter-clockwise [rad].

One helper wraps angles (`wrap_angle`); poses are `Pose2D` values in a named frame's
coordinates (usually ``map``, REP-105). Composition follows the usual SE(2) rules:
``a.compose(b)`` is ``b`` expressed in the frame of ``a`` mapped into ``a``'s parent frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def wrap_angle(angle: float) -> float:
    """Wrap an angle to (-pi, pi] [rad]."""
    wrapped = math.remainder(angle, math.tau)
    # math.remainder maps pi to pi and -pi to -pi; keep the half-open interval (-pi, pi].
    if wrapped <= -math.pi:
        wrapped += math.tau
    return wrapped


def angle_diff(a: float, b: float) -> float:
    """Signed smallest difference a - b, wrapped to (-pi, pi] [rad]."""
    return wrap_angle(a - b)


@dataclass(frozen=True, slots=True, init=False)
class Pose2D:
    """A planar pose: position [m] and heading yaw [rad], yaw wrapped to (-pi, pi]."""

    x: float
    y: float
    yaw: float

    def __init__(self, x: float, y: float, yaw: float) -> None:
        # Written out rather than the dataclass's __init__ and a __post_init__ that sets every
        # field twice: poses are made by the hundred thousand in a simulated tour.
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            for name, value in (("x", x), ("y", y), ("yaw", yaw)):
                if not math.isfinite(value):
                    raise ValueError(f"Pose2D.{name} must be finite, got {value!r}")
        setattr_ = object.__setattr__
        setattr_(self, "x", float(x))
        setattr_(self, "y", float(y))
        setattr_(self, "yaw", wrap_angle(float(yaw)))

    def distance_to(self, other: Pose2D) -> float:
        """Euclidean distance between the two positions [m]."""
        return math.hypot(other.x - self.x, other.y - self.y)

    def compose(self, delta: Pose2D) -> Pose2D:
        """self ⊕ delta: apply ``delta`` (given in this pose's frame) to this pose."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            self.x + c * delta.x - s * delta.y,
            self.y + s * delta.x + c * delta.y,
            self.yaw + delta.yaw,
        )

    def inverse(self) -> Pose2D:
        """The pose ⊖self, so that ``self.compose(self.inverse())`` is the identity."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(-c * self.x - s * self.y, s * self.x - c * self.y, -self.yaw)

    def relative_to(self, origin: Pose2D) -> Pose2D:
        """This pose expressed in the frame of ``origin`` (origin⊖ ⊕ self)."""
        return origin.inverse().compose(self)
