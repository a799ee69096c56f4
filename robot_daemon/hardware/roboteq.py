"""RoboteQ motor controller (thesis §4.1.8): command formatting, reply parsing and odometry.

Reference: RoboteQ "Advanced Digital Motor Controller User Manual" (serial commands,
runtime queries, configuration ``RWD``, ``ECHOF``), summarised in shared/FIELD_NOTES.md.
Pure functions and value types only; `roboteq_driver` owns the serial port.

Serial syntax: every command ends with CR. Motor commands start with ``!`` (``!G ch v`` with
v in -1000..1000, relative to the configured max RPM in closed-loop speed mode; ``!S ch rpm``);
queries with ``?`` and answer ``NAME=v1:v2``; configuration with ``^``. Commands are answered
``+`` (done) or ``-`` (refused). ``^ECHOF 1`` stops the echo of received characters.

Differential drive (REP-103, track b, wheel radius r, gear ratio g motor turns per wheel turn):

    v_l = v - omega b / 2,   v_r = v + omega b / 2          [m/s]
    rpm_motor = v_wheel / r * 60 / (2 pi) * g

Odometry from absolute encoder counts (``?C``; 32-bit signed, wrapping) with N counts per
motor turn: ``d = Delta counts / (N g) * 2 pi r`` (each wheel with its own radius r), ``ds = (d_r + d_l) / 2``,
``dtheta = (d_r - d_l) / b``, integrated exactly along the arc of constant curvature:

    x += ds / dtheta * (sin(theta + dtheta) - sin theta)
    y += ds / dtheta * (cos theta - cos(theta + dtheta))

(the straight-line limit ``ds cos(theta), ds sin(theta)`` when dtheta -> 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interbot_core.geometry import Pose2D
from robot_daemon.backend import OdometryReading
from robot_daemon.hardware.config import MotorsConfig
from robot_daemon.sim.battery import OCV_CELL, OCV_SOC
from robot_daemon.sim.diff_drive import integrate_arc, wheel_speeds

CR = b"\r"
G_LIMIT = 1000  # !G range is -1000..1000
COUNTER_MODULUS = 1 << 32  # encoder counters are signed 32-bit and wrap

#: ``?FF`` bits, f1 = bit 0 (manual: "FF - Read Fault Flags").
FAULT_FLAGS: tuple[str, ...] = (
    "overheat",
    "overvoltage",
    "undervoltage",
    "short circuit",
    "emergency stop",
    "sensor fault",
    "MOSFET failure",
    "default configuration loaded at startup",
)


class RoboteqError(ValueError):
    """A malformed or unexpected controller reply."""


# -- commands ---------------------------------------------------------------------------------


def motor_command(kind: str, channel: int, value: int) -> bytes:
    """``!G 1 500\\r`` or ``!S 2 -120\\r``."""
    if kind not in ("G", "S"):
        raise ValueError(f"motor command must be G or S, got {kind!r}")
    if channel not in (1, 2):
        raise ValueError(f"RoboteQ channel must be 1 or 2, got {channel}")
    return f"!{kind} {channel} {int(value)}".encode("ascii") + CR


def query(name: str, channel: int | None = None) -> bytes:
    """``?C\\r`` (all channels) or ``?C 1\\r``."""
    text = f"?{name}" if channel is None else f"?{name} {channel}"
    return text.encode("ascii") + CR


def config_command(name: str, value: int) -> bytes:
    """``^RWD 500\\r``, ``^ECHOF 1\\r``."""
    return f"^{name} {int(value)}".encode("ascii") + CR


# -- replies ----------------------------------------------------------------------------------


def parse_query_reply(line: bytes, name: str) -> tuple[int, ...]:
    """``C=123:-45`` -> (123, -45) for query ``name``; raises `RoboteqError` otherwise."""
    text = line.decode("ascii", errors="replace").strip()
    prefix = f"{name}="
    if not text.startswith(prefix):
        raise RoboteqError(f"expected a {prefix!r} reply, got {text!r}")
    try:
        return tuple(int(v) for v in text[len(prefix) :].split(":"))
    except ValueError:
        raise RoboteqError(f"non-integer field in reply {text!r}") from None


@dataclass(frozen=True)
class Voltages:
    """``?V``: ``V=internal:battery:5V`` (volts x10, volts x10, millivolts)."""

    internal: float  # [V]
    battery: float  # [V]
    five_volt: float  # [V]


def parse_voltages(line: bytes) -> Voltages:
    values = parse_query_reply(line, "V")
    if len(values) != 3:
        raise RoboteqError(f"?V reply needs internal:battery:5V, got {values}")
    return Voltages(values[0] / 10.0, values[1] / 10.0, values[2] / 1000.0)


def parse_battery_current(line: bytes) -> float:
    """``?BA``: battery CURRENT per channel in amps x10 (not a voltage); returns the total [A]."""
    values = parse_query_reply(line, "BA")
    return sum(values) / 10.0


def parse_fault_flags(line: bytes) -> int:
    """``?FF``: the fault bit field."""
    values = parse_query_reply(line, "FF")
    if len(values) != 1 or not 0 <= values[0] <= 0xFF:
        raise RoboteqError(f"?FF reply must be one value in 0..255, got {values}")
    return values[0]


def fault_names(flags: int) -> list[str]:
    """Names of the set fault bits."""
    return [name for bit, name in enumerate(FAULT_FLAGS) if flags >> bit & 1]


# -- kinematics -------------------------------------------------------------------------------


@dataclass(frozen=True)
class WheelCommand:
    """What to send for one twist: the two channel values, and whether it was clamped."""

    left: int
    right: int
    clamped: bool
    scale: float  # factor applied to both wheels (1.0 when not clamped)


def twist_to_command(
    geometry: MotorsConfig, linear: float, angular: float, kind: str
) -> WheelCommand:
    """Body twist -> channel values for ``!G`` (per mille of max rpm) or ``!S`` (rpm).

    If a wheel would exceed ``max_rpm``, both wheels are scaled by the same factor so the
    robot keeps its path curvature (only slower), and ``clamped`` is set.
    """
    if not (math.isfinite(linear) and math.isfinite(angular)):
        linear = angular = 0.0
    v_l, v_r = wheel_speeds(linear, angular, geometry.track)
    r_l, r_r = geometry.radii
    rpm_l, rpm_r = geometry.motor_rpm(v_l, r_l), geometry.motor_rpm(v_r, r_r)
    peak = max(abs(rpm_l), abs(rpm_r))
    scale = 1.0 if peak <= geometry.max_rpm else geometry.max_rpm / peak
    rpm_l, rpm_r = rpm_l * scale, rpm_r * scale
    if kind == "G":
        limit = G_LIMIT
        left = round(rpm_l / geometry.max_rpm * G_LIMIT)
        right = round(rpm_r / geometry.max_rpm * G_LIMIT)
    elif kind == "S":
        limit = math.floor(geometry.max_rpm)
        left, right = round(rpm_l), round(rpm_r)
    else:
        raise ValueError(f"command kind must be G or S, got {kind!r}")
    left = max(-limit, min(limit, left))
    right = max(-limit, min(limit, right))
    return WheelCommand(left, right, scale < 1.0, scale)


def counter_delta(new: int, old: int) -> int:
    """Signed difference of two 32-bit wrapping counters."""
    return (new - old + COUNTER_MODULUS // 2) % COUNTER_MODULUS - COUNTER_MODULUS // 2


class WheelOdometry:
    """Integrates absolute encoder counts into an ``odom`` pose (starts at the origin)."""

    def __init__(self, geometry: MotorsConfig, left_sign: int = 1, right_sign: int = 1) -> None:
        self.geometry = geometry
        self.left_sign = left_sign
        self.right_sign = right_sign
        self._counts: tuple[int, int] | None = None
        self._state: OdometryReading | None = None

    @property
    def state(self) -> OdometryReading | None:
        return self._state

    def rebase(self) -> None:
        """Forget the last counts (after a reconnect: the controller may have reset them)."""
        self._counts = None

    def update(self, left_counts: int, right_counts: int, stamp: float) -> OdometryReading:
        """Add the motion since the previous counts; the first call only sets the reference."""
        if self._counts is None or self._state is None:
            self._counts = (left_counts, right_counts)
            pose = self._state.pose if self._state else Pose2D(0.0, 0.0, 0.0)
            self._state = OdometryReading(stamp, pose, 0.0, 0.0)
            return self._state
        g = self.geometry
        m_l, m_r = g.metres_per_count_lr
        d_l = self.left_sign * counter_delta(left_counts, self._counts[0]) * m_l
        d_r = self.right_sign * counter_delta(right_counts, self._counts[1]) * m_r
        self._counts = (left_counts, right_counts)
        ds = (d_r + d_l) / 2.0
        dtheta = (d_r - d_l) / g.track
        dt = stamp - self._state.stamp
        linear, angular = (ds / dt, dtheta / dt) if dt > 0 else (0.0, 0.0)
        self._state = OdometryReading(
            stamp, integrate_arc(self._state.pose, ds, dtheta, 1.0), linear, angular
        )
        return self._state


# -- battery ----------------------------------------------------------------------------------

# Li-ion (NMC) open-circuit voltage per cell against state of charge: the simulated BMS's curve
# (`robot_daemon.sim.battery`), an assumption: the thesis gives none.


def state_of_charge(
    voltage: float, current: float, cells: int, internal_resistance: float
) -> float:
    """SOC [0, 1] from the terminal voltage, corrected for the I R drop (Rint model)."""
    cell_ocv = (voltage + current * internal_resistance) / cells
    return float(np.interp(cell_ocv, OCV_CELL, OCV_SOC))
