"""The robot's hardware seen by the daemon: one interface, two kinds of backend.

The simulator (`robot_daemon.sim_backend.SimBackend`) and the real devices (Hokuyo laser,
RoboteQ motor controller, USB camera; `robot_daemon.hardware`) both implement `RobotBackend`,
so the localiser, planner and multiplexer never know which one they drive. Calls are made from
the daemon's single control loop, with ``now`` the daemon's monotonic (or simulated) time [s].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan


@dataclass(frozen=True)
class OdometryReading:
    """Wheel odometry: the ``odom``-frame pose (REP-105: continuous, drifts) and body velocities."""

    stamp: float  # [s]
    pose: Pose2D  # odom frame
    linear: float  # [m/s]
    angular: float  # [rad/s]


@dataclass(frozen=True)
class BatteryReading:
    """The BMS (thesis §4.1.7): pack voltage, current (positive = discharge) and charge."""

    stamp: float  # [s]
    voltage: float  # [V]
    current: float  # [A]
    state_of_charge: float  # [0, 1]


@dataclass(frozen=True)
class DeviceStatus:
    """Health of one device, shown in the robot status (counters are totals since start)."""

    name: str
    ok: bool
    message: str = ""
    counters: dict[str, int] = field(default_factory=dict)


class RobotBackend(Protocol):
    """What the daemon needs from a robot, simulated or real."""

    def set_cmd_vel(self, linear: float, angular: float, now: float) -> None:
        """Command body velocities [m/s, rad/s]; the backend clamps to its limits."""

    def read_odometry(self, now: float) -> OdometryReading | None:
        """The newest odometry, or None if none arrived yet."""

    def read_scan(self, now: float) -> LaserScan | None:
        """A complete scan newer than the last one returned, else None (never a partial scan)."""

    def read_camera_jpeg(self, now: float) -> bytes | None:
        """A JPEG frame newer than the last one returned, else None."""

    def read_battery(self, now: float) -> BatteryReading | None:
        """The newest battery reading, or None."""

    def device_status(self) -> list[DeviceStatus]:
        """Health of each device."""

    def close(self) -> None:
        """Stop the motors and release the devices (idempotent)."""
