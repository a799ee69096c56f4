"""Differential-drive kinematics with velocity/acceleration limits, and the robot footprint.

Interbot has two 24 V DC motors driving two wheels on one axle (thesis §4.1, Fig. 4.1), so the
base is a differential drive. For a body velocity (v, omega) the wheel rim speeds are

    v_left = v - omega * b / 2,    v_right = v + omega * b / 2,

with b the track width, and conversely ``v = (v_left + v_right) / 2``,
``omega = (v_right - v_left) / b``. Holding (v, omega) constant over dt the base follows an arc,
integrated exactly (Siegwart & Nourbakhsh, *Introduction to Autonomous Mobile Robots*, §5.2.4):

    dtheta = omega * dt,  chord = v * dt * sin(dtheta/2) / (dtheta/2),
    x += chord * cos(theta + dtheta/2),  y += chord * sin(theta + dtheta/2),  theta += dtheta.

The footprint is a rectangle (default 0.60 m long, 0.55 m wide) centred on ``base_link`` plus an
optional offset, in REP-103 axes (x forward, y left).
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D

FloatArray = npt.NDArray[np.float64]


class DiffDriveConfigError(ValueError):
    """A drive or footprint parameter is out of range; the message names the field."""


Positive = Annotated[float, Meta(gt=0.0, le=schema.FINITE)]


class DiffDriveConfig(schema.Declared, frozen=True):
    """Drive geometry and limits (limits default to thesis-era Interbot teleoperation values)."""

    ROOT: ClassVar[str] = "DiffDriveConfig"
    ERROR: ClassVar[type[Exception]] = DiffDriveConfigError
    track_width: Positive = 0.46  # [m] distance between the wheel contact points
    wheel_radius: Positive = 0.10  # [m]
    max_linear: Positive = 0.8  # [m/s]
    max_angular: Positive = 1.5  # [rad/s]
    max_linear_accel: Positive = 0.6  # [m/s^2]
    max_angular_accel: Positive = 2.0  # [rad/s^2]


def _sin_x_over_x(a: float) -> float:
    """sin(a)/a, with its Taylor series near zero."""
    if abs(a) < 1e-4:
        return 1.0 - a * a / 6.0
    return math.sin(a) / a


def integrate_arc(pose: Pose2D, linear: float, angular: float, dt: float) -> Pose2D:
    """Exact pose after moving at constant (linear [m/s], angular [rad/s]) for dt [s]."""
    dtheta = angular * dt
    chord = linear * dt * _sin_x_over_x(0.5 * dtheta)
    mid = pose.yaw + 0.5 * dtheta
    return Pose2D(pose.x + chord * math.cos(mid), pose.y + chord * math.sin(mid), pose.yaw + dtheta)


def wheel_speeds(linear: float, angular: float, track_width: float) -> tuple[float, float]:
    """(v_left, v_right) wheel rim speeds [m/s] for a body velocity."""
    half = 0.5 * angular * track_width
    return linear - half, linear + half


def body_velocity(v_left: float, v_right: float, track_width: float) -> tuple[float, float]:
    """(linear [m/s], angular [rad/s]) from wheel rim speeds [m/s]."""
    return 0.5 * (v_left + v_right), (v_right - v_left) / track_width


def _approach(current: float, target: float, max_step: float) -> float:
    return current + min(max(target - current, -max_step), max_step)


class DiffDrive:
    """The velocity loop of the motor controller: clamps and rate-limits commanded velocities.

    ``command`` sets the target (clamped to the speed limits); ``advance(dt)`` moves the actual
    body velocity towards it within the acceleration limits and returns the mean velocity over
    the step, which ``integrate_arc`` then applies.
    """

    def __init__(self, config: DiffDriveConfig | None = None) -> None:
        self.config = config or DiffDriveConfig()
        self._target = (0.0, 0.0)
        self._linear = 0.0
        self._angular = 0.0

    @property
    def velocity(self) -> tuple[float, float]:
        """Current (linear [m/s], angular [rad/s])."""
        return self._linear, self._angular

    @property
    def target(self) -> tuple[float, float]:
        """Clamped commanded (linear [m/s], angular [rad/s])."""
        return self._target

    def command(self, linear: float, angular: float) -> None:
        """Set the target velocity; non-finite values are treated as zero (a safe stop)."""
        c = self.config
        lin = float(linear) if math.isfinite(linear) else 0.0
        ang = float(angular) if math.isfinite(angular) else 0.0
        self._target = (
            min(max(lin, -c.max_linear), c.max_linear),
            min(max(ang, -c.max_angular), c.max_angular),
        )

    def stop(self) -> None:
        """Zero velocity and target at once (a collision or an emergency stop)."""
        self._target = (0.0, 0.0)
        self._linear = 0.0
        self._angular = 0.0

    def advance(self, dt: float) -> tuple[float, float]:
        """Accelerate towards the target for dt [s]; return the mean (linear, angular) over dt."""
        c = self.config
        lin0, ang0 = self._linear, self._angular
        self._linear = _approach(lin0, self._target[0], c.max_linear_accel * dt)
        self._angular = _approach(ang0, self._target[1], c.max_angular_accel * dt)
        return 0.5 * (lin0 + self._linear), 0.5 * (ang0 + self._angular)


class RobotFootprint(schema.Declared, frozen=True):
    """A rectangle ``length`` x ``width`` [m] whose centre sits at (offset_x, offset_y) in base_link."""

    ROOT: ClassVar[str] = "RobotFootprint"
    ERROR: ClassVar[type[Exception]] = DiffDriveConfigError
    length: Positive = 0.60  # [m] along x
    width: Positive = 0.55  # [m] along y
    offset_x: schema.Finite = 0.0  # [m]
    offset_y: schema.Finite = 0.0  # [m]

    @property
    def circumscribed_radius(self) -> float:
        """Radius [m] around base_link that contains the whole footprint."""
        return math.hypot(abs(self.offset_x) + self.length / 2, abs(self.offset_y) + self.width / 2)

    def inflated(self, margin: float) -> RobotFootprint:
        """The same rectangle grown by ``margin`` [m] on every side."""
        return RobotFootprint(
            self.length + 2 * margin, self.width + 2 * margin, self.offset_x, self.offset_y
        )

    def corners_local(self) -> FloatArray:
        """(4, 2) corners in base_link, counter-clockwise from front-left."""
        hl, hw = self.length / 2, self.width / 2
        corners = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]], dtype=np.float64)
        corners += np.array([self.offset_x, self.offset_y])
        return corners

    def outline_local(self, spacing: float) -> FloatArray:
        """(N, 2) points along the outline in base_link, no two further apart than ``spacing``."""
        if not (math.isfinite(spacing) and spacing > 0):
            raise DiffDriveConfigError(
                f"outline spacing must be a finite number > 0, got {spacing!r}"
            )
        corners = self.corners_local()
        pieces = []
        for i in range(4):
            a, b = corners[i], corners[(i + 1) % 4]
            n = max(1, math.ceil(float(np.hypot(*(b - a))) / spacing))
            s = np.arange(n, dtype=np.float64)[:, None] / n
            pieces.append(a + s * (b - a))
        return np.vstack(pieces)

    def area_local(self, spacing: float) -> FloatArray:
        """(N, 2) outline points plus an interior lattice of pitch ``spacing`` in base_link."""
        nx = max(2, math.ceil(self.length / spacing) + 1)
        ny = max(2, math.ceil(self.width / spacing) + 1)
        gx, gy = np.meshgrid(
            np.linspace(-self.length / 2, self.length / 2, nx),
            np.linspace(-self.width / 2, self.width / 2, ny),
        )
        inner = np.column_stack((gx.ravel() + self.offset_x, gy.ravel() + self.offset_y))
        return np.vstack((self.outline_local(spacing / 2), inner))

    def distance_to_point(self, pose: Pose2D, x: float, y: float) -> float:
        """Scalar `distance_to_points` for one world point [m] (pure Python, fast)."""
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        dx, dy = x - pose.x, y - pose.y
        ex = max(abs(c * dx + s * dy - self.offset_x) - self.length / 2, 0.0)
        ey = max(abs(-s * dx + c * dy - self.offset_y) - self.width / 2, 0.0)
        return math.hypot(ex, ey)

    def distance_to_points(self, pose: Pose2D, points: npt.ArrayLike) -> FloatArray:
        """Euclidean distance [m] from each world point (N, 2) to the rectangle (0 inside)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        dx, dy = pts[:, 0] - pose.x, pts[:, 1] - pose.y
        lx = c * dx + s * dy - self.offset_x
        ly = -s * dx + c * dy - self.offset_y
        ex = np.maximum(np.abs(lx) - self.length / 2, 0.0)
        ey = np.maximum(np.abs(ly) - self.width / 2, 0.0)
        result: FloatArray = np.hypot(ex, ey)
        return result


def to_world(pose: Pose2D, local: FloatArray) -> FloatArray:
    """Transform (N, 2) base_link points into the world frame of ``pose``."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    rot = np.array([[c, -s], [s, c]])
    result: FloatArray = local @ rot.T + np.array([pose.x, pose.y])
    return result
