"""The ``hardware:`` section of robot.yaml, declared as msgspec Structs (types carry the ranges).

Every error names the key (``hardware.motors.track``) and the allowed range. Example (see
deploy/robot.yaml)::

    hardware:
      laser: {port: /dev/ttyACM0, baudrate: 115200}
      motors: {port: /dev/ttyUSB0, wheel_radius: 0.1, track: 0.5, counts_per_rev: 2048,
               gear_ratio: 20, max_rpm: 3000, command: G, watchdog_ms: 500}
      camera: {device: 0, width: 320, height: 240, fps: 10, jpeg_quality: 70}
      battery: {cells: 8, internal_resistance: 0.08}

Optional keys have the defaults shown in the declarations below.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

import msgspec
from msgspec import Meta

from interbot_core import schema
from robot_daemon.config import ConfigError


class HardwareConfigError(ConfigError):
    """Invalid ``hardware:`` configuration; the message names the key."""


Port = Annotated[str, Meta(pattern=r"\S", extra={"format": "a device path such as /dev/ttyACM0"})]
Baud = Annotated[int, Meta(ge=9600, le=1_000_000)]
Delay = Annotated[float, Meta(ge=0.01, le=60.0)]  # [s]


class _Section(schema.Declared, frozen=True):
    ERROR: ClassVar[type[Exception]] = HardwareConfigError


class LaserConfig(_Section, frozen=True):
    """Hokuyo UTM-30LX on USB (CDC-ACM; the baud rate is ignored by USB but kept for RS-232)."""

    ROOT: ClassVar[str] = "hardware.laser"
    port: Port = "/dev/ttyACM0"
    baudrate: Baud = 115200
    # [s] no byte for this long = stalled device, reconnect
    stall_timeout: Annotated[float, Meta(ge=0.05, le=10.0)] = 0.5
    reconnect_delay: Delay = 1.0  # [s] between reconnection attempts


WheelRadius = Annotated[float, Meta(ge=0.01, le=1.0)]  # [m]


class MotorsConfig(_Section, frozen=True):
    """RoboteQ controller and the drive's kinematic parameters (thesis §6.1.1 calibration)."""

    ROOT: ClassVar[str] = "hardware.motors"
    port: Port = "/dev/ttyUSB0"
    wheel_radius: WheelRadius = 0.1
    track: Annotated[float, Meta(ge=0.05, le=3.0)] = 0.5  # [m]
    # Per-wheel radii from `interbot calibrate odometry` (UMBmark); absent: wheel_radius.
    wheel_radius_left: WheelRadius | None = None
    wheel_radius_right: WheelRadius | None = None
    # encoder counts per motor turn (4 x PPR)
    counts_per_rev: Annotated[float, Meta(ge=1, le=1_000_000)] = 2048.0
    gear_ratio: Annotated[float, Meta(ge=0.01, le=1000)] = 20.0  # motor turns per wheel turn
    max_rpm: Annotated[float, Meta(ge=1, le=100_000)] = 3000.0  # motor rpm at !G 1000 (MXRPM)
    command: Annotated[str, schema.one_of("G", "S")] = "G"  # G: !G per mille, S: !S rpm
    watchdog_ms: Annotated[int, Meta(ge=50, le=65000)] = 500  # controller watchdog ^RWD [ms]
    baudrate: Baud = 115200
    left_channel: Literal[1, 2] = 1  # the other channel drives the right wheel
    left_sign: Literal[1, -1] = 1  # -1 if the left motor is mounted mirrored
    right_sign: Literal[1, -1] = 1
    poll_hz: Annotated[float, Meta(ge=1, le=200)] = 50.0  # encoder polling rate
    reconnect_delay: Delay = 1.0

    # The kinematics (the parameters tuned in the thesis §6.1.1.2 calibration): the per-wheel
    # radii override ``wheel_radius``, since unequal wheels are what makes a straight run curve.

    @property
    def radii(self) -> tuple[float, float]:
        """(left, right) wheel radius [m]."""
        left = self.wheel_radius if self.wheel_radius_left is None else self.wheel_radius_left
        right = self.wheel_radius if self.wheel_radius_right is None else self.wheel_radius_right
        return left, right

    @property
    def metres_per_count_lr(self) -> tuple[float, float]:
        """(left, right) rim travel per encoder count [m]."""
        k = math.tau / (self.counts_per_rev * self.gear_ratio)
        left, right = self.radii
        return k * left, k * right

    def motor_rpm(self, wheel_speed: float, radius: float | None = None) -> float:
        """Motor shaft rpm for a wheel rim speed [m/s] (``radius`` [m]: nominal if None)."""
        r = self.wheel_radius if radius is None else radius
        return wheel_speed / r * 60.0 / math.tau * self.gear_ratio

    @property
    def right_channel(self) -> int:
        return 3 - self.left_channel


class CameraConfig(_Section, frozen=True):
    """USB camera opened with OpenCV; ``device`` is an index (0) or a path (/dev/video0)."""

    ROOT: ClassVar[str] = "hardware.camera"
    device: Annotated[
        Annotated[int, Meta(ge=0)] | str, Meta(extra={"format": "an index or a path (index >= 0)"})
    ] = 0
    width: Annotated[int, Meta(ge=16, le=4096)] = 320
    height: Annotated[int, Meta(ge=16, le=4096)] = 240
    fps: Annotated[float, Meta(ge=0.1, le=120)] = 10.0
    jpeg_quality: Annotated[int, Meta(ge=1, le=100)] = 70
    enabled: bool = True
    reopen_delay: Delay = 2.0  # [s] between attempts while the camera is missing


class BatteryConfig(_Section, frozen=True):
    """The pack behind the controller's ``?V``/``?BA`` (8 Li-ion cells, thesis Fig. 4.1)."""

    ROOT: ClassVar[str] = "hardware.battery"
    cells: Annotated[int, Meta(ge=1, le=32)] = 8
    # [ohm] pack, for the SOC estimate
    internal_resistance: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.08


class HardwareConfig(_Section, frozen=True):
    ROOT: ClassVar[str] = "hardware"
    laser: LaserConfig = msgspec.field(default_factory=LaserConfig)
    motors: MotorsConfig = msgspec.field(default_factory=MotorsConfig)
    camera: CameraConfig = msgspec.field(default_factory=CameraConfig)
    battery: BatteryConfig = msgspec.field(default_factory=BatteryConfig)

    @classmethod
    def from_mapping(
        cls, raw: Mapping[str, Any] | None, source: str = "robot.yaml"
    ) -> HardwareConfig:
        """Validate the ``hardware:`` mapping; errors are prefixed with ``source``."""
        return schema.load(raw or {}, cls, "hardware", source, HardwareConfigError)
