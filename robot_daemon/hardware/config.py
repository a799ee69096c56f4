"""The ``hardware:`` section of robot.yaml, parsed into frozen, validated dataclasses.

Every error names the key (``hardware.motors.track``) and the allowed range. Example (see
deploy/robot.yaml)::

    hardware:
      laser: {port: /dev/ttyACM0, baudrate: 115200}
      motors: {port: /dev/ttyUSB0, wheel_radius: 0.1, track: 0.5, counts_per_rev: 2048,
               gear_ratio: 20, max_rpm: 3000, command: G, watchdog_ms: 500}
      camera: {device: 0, width: 320, height: 240, fps: 10, jpeg_quality: 70}
      battery: {cells: 8, internal_resistance: 0.08}

Optional keys have the defaults shown in the dataclasses below.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from robot_daemon.hardware.roboteq import DriveGeometry


class HardwareConfigError(ValueError):
    """Invalid ``hardware:`` configuration; the message names the key."""


def _check_number(
    where: str, key: str, value: Any, low: float, high: float, integer: bool = False
) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise HardwareConfigError(f"{where}.{key} must be a number, got {value!r}")
    if integer and not isinstance(value, int):
        raise HardwareConfigError(f"{where}.{key} must be an integer, got {value!r}")
    if not low <= value <= high:
        raise HardwareConfigError(f"{where}.{key} = {value} is outside [{low}, {high}]")


def _check_port(where: str, value: Any) -> None:
    if not isinstance(value, str) or not value:
        raise HardwareConfigError(f"{where}.port must be a device path such as /dev/ttyACM0")


@dataclass(frozen=True)
class LaserConfig:
    """Hokuyo UTM-30LX on USB (CDC-ACM; the baud rate is ignored by USB but kept for RS-232)."""

    port: str = "/dev/ttyACM0"
    baudrate: int = 115200
    stall_timeout: float = 0.5  # [s] no byte for this long = stalled device, reconnect
    reconnect_delay: float = 1.0  # [s] between reconnection attempts

    def __post_init__(self) -> None:
        w = "hardware.laser"
        _check_port(w, self.port)
        _check_number(w, "baudrate", self.baudrate, 9600, 1_000_000, integer=True)
        _check_number(w, "stall_timeout", self.stall_timeout, 0.05, 10.0)
        _check_number(w, "reconnect_delay", self.reconnect_delay, 0.01, 60.0)


@dataclass(frozen=True)
class MotorsConfig:
    """RoboteQ controller and the drive's kinematic parameters (thesis §6.1.1 calibration)."""

    port: str = "/dev/ttyUSB0"
    wheel_radius: float = 0.1  # [m]
    track: float = 0.5  # [m]
    # Per-wheel radii from `interbot calibrate odometry` (UMBmark); absent: wheel_radius.
    wheel_radius_left: float | None = None  # [m]
    wheel_radius_right: float | None = None  # [m]
    counts_per_rev: float = 2048.0  # encoder counts per motor turn (4 x PPR)
    gear_ratio: float = 20.0  # motor turns per wheel turn
    max_rpm: float = 3000.0  # motor rpm at !G 1000 (controller MXRPM)
    command: str = "G"  # G: !G per mille of max_rpm, S: !S rpm
    watchdog_ms: int = 500  # controller serial watchdog ^RWD [ms]
    baudrate: int = 115200
    left_channel: int = 1  # the other channel drives the right wheel
    left_sign: int = 1  # -1 if the left motor is mounted mirrored
    right_sign: int = 1
    poll_hz: float = 50.0  # encoder polling rate
    reconnect_delay: float = 1.0  # [s]

    def __post_init__(self) -> None:
        w = "hardware.motors"
        _check_port(w, self.port)
        _check_number(w, "wheel_radius", self.wheel_radius, 0.01, 1.0)
        _check_number(w, "track", self.track, 0.05, 3.0)
        for key in ("wheel_radius_left", "wheel_radius_right"):
            if getattr(self, key) is not None:
                _check_number(w, key, getattr(self, key), 0.01, 1.0)
        _check_number(w, "counts_per_rev", self.counts_per_rev, 1, 1_000_000)
        _check_number(w, "gear_ratio", self.gear_ratio, 0.01, 1000)
        _check_number(w, "max_rpm", self.max_rpm, 1, 100_000)
        if self.command not in ("G", "S"):
            raise HardwareConfigError(f"{w}.command must be G or S, got {self.command!r}")
        _check_number(w, "watchdog_ms", self.watchdog_ms, 50, 65000, integer=True)
        _check_number(w, "baudrate", self.baudrate, 9600, 1_000_000, integer=True)
        if self.left_channel not in (1, 2):
            raise HardwareConfigError(f"{w}.left_channel must be 1 or 2, got {self.left_channel!r}")
        for key in ("left_sign", "right_sign"):
            if getattr(self, key) not in (1, -1):
                raise HardwareConfigError(f"{w}.{key} must be 1 or -1, got {getattr(self, key)!r}")
        _check_number(w, "poll_hz", self.poll_hz, 1, 200)
        _check_number(w, "reconnect_delay", self.reconnect_delay, 0.01, 60.0)

    @property
    def geometry(self) -> DriveGeometry:
        return DriveGeometry(
            float(self.wheel_radius),
            float(self.track),
            float(self.counts_per_rev),
            float(self.gear_ratio),
            float(self.max_rpm),
            None if self.wheel_radius_left is None else float(self.wheel_radius_left),
            None if self.wheel_radius_right is None else float(self.wheel_radius_right),
        )

    @property
    def right_channel(self) -> int:
        return 3 - self.left_channel


@dataclass(frozen=True)
class CameraConfig:
    """USB camera opened with OpenCV; ``device`` is an index (0) or a path (/dev/video0)."""

    device: int | str = 0
    width: int = 320
    height: int = 240
    fps: float = 10.0
    jpeg_quality: int = 70
    enabled: bool = True
    reopen_delay: float = 2.0  # [s] between attempts while the camera is missing

    def __post_init__(self) -> None:
        w = "hardware.camera"
        if isinstance(self.device, bool) or not isinstance(self.device, int | str):
            raise HardwareConfigError(f"{w}.device must be an index or a path, got {self.device!r}")
        if isinstance(self.device, int) and self.device < 0:
            raise HardwareConfigError(f"{w}.device index must be >= 0, got {self.device}")
        _check_number(w, "width", self.width, 16, 4096, integer=True)
        _check_number(w, "height", self.height, 16, 4096, integer=True)
        _check_number(w, "fps", self.fps, 0.1, 120)
        _check_number(w, "jpeg_quality", self.jpeg_quality, 1, 100, integer=True)
        if not isinstance(self.enabled, bool):
            raise HardwareConfigError(f"{w}.enabled must be true or false")
        _check_number(w, "reopen_delay", self.reopen_delay, 0.01, 60.0)


@dataclass(frozen=True)
class BatteryConfig:
    """The pack behind the controller's ``?V``/``?BA`` (8 Li-ion cells, thesis Fig. 4.1)."""

    cells: int = 8
    internal_resistance: float = 0.08  # [ohm] pack, for the SOC estimate

    def __post_init__(self) -> None:
        _check_number("hardware.battery", "cells", self.cells, 1, 32, integer=True)
        _check_number("hardware.battery", "internal_resistance", self.internal_resistance, 0.0, 5.0)


@dataclass(frozen=True)
class HardwareConfig:
    laser: LaserConfig = field(default_factory=LaserConfig)
    motors: MotorsConfig = field(default_factory=MotorsConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    battery: BatteryConfig = field(default_factory=BatteryConfig)

    @classmethod
    def from_mapping(
        cls, raw: Mapping[str, Any] | None, source: str = "robot.yaml"
    ) -> HardwareConfig:
        """Validate the ``hardware:`` mapping; errors are prefixed with ``source``."""
        raw = raw or {}
        if not isinstance(raw, Mapping):
            raise HardwareConfigError(f"{source}: 'hardware' must be a mapping")
        sections: dict[str, type] = {
            "laser": LaserConfig,
            "motors": MotorsConfig,
            "camera": CameraConfig,
            "battery": BatteryConfig,
        }
        unknown = set(raw) - set(sections)
        if unknown:
            raise HardwareConfigError(
                f"{source}: unknown key(s) {sorted(unknown)} in 'hardware' "
                f"(allowed: {sorted(sections)})"
            )
        built: dict[str, Any] = {}
        for name, section_cls in sections.items():
            value = raw.get(name, {})
            if not isinstance(value, Mapping):
                raise HardwareConfigError(f"{source}: 'hardware.{name}' must be a mapping")
            allowed = {f.name for f in fields(section_cls)}
            extra = set(value) - allowed
            if extra:
                raise HardwareConfigError(
                    f"{source}: unknown key(s) {sorted(extra)} in 'hardware.{name}' "
                    f"(allowed: {sorted(allowed)})"
                )
            try:
                built[name] = section_cls(**value)
            except HardwareConfigError as exc:
                raise HardwareConfigError(f"{source}: {exc}") from None
        return cls(**built)
