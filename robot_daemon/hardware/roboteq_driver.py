"""RoboteQ motor controller driver (thesis §4.1.8, §6.1): velocity commands, odometry, battery.

One thread owns the serial port (115200 8N1, commands end with CR). At every (re)connection
it sends ``^ECHOF 1`` (no echo), ``^RWD <watchdog_ms>`` (the controller stops the motors if
no ``!`` command arrives for that long, so a hung daemon cannot leave the robot driving) and
zero on both channels. Then, at ``poll_hz``:

- the newest `set_cmd_vel` twist, if one arrived since the last cycle, becomes ``!G``/``!S`` on
  both channels (`roboteq.twist_to_command`: both wheels scaled together when one would exceed
  max_rpm, counted and logged when that starts). Nothing is re-sent on the daemon's behalf: if
  the daemon stops commanding, the controller's watchdog stops the robot.
- ``?C`` (absolute counts of both channels; read only here — ``?CR`` would be destructive)
  feeds `roboteq.WheelOdometry`.
- about once a second ``?V`` (battery volts x10), ``?BA`` (battery CURRENT, amps x10) and
  ``?FF`` (fault flags).

The watchdog trap: after a trip the controller resumes the speed it had before as soon as the
next ``!`` command arrives. So whenever a trip may have happened (no ``!`` sent for 80 % of
the watchdog period, or a new connection), zero is sent on both channels in one write
before the new command. Unanswered queries, ``-`` replies and unreadable lines are counted;
three unanswered exchanges in a row, or a serial error, close the port and the driver
reconnects every ``reconnect_delay`` seconds.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import serial

from robot_daemon.backend import BatteryReading, DeviceStatus, OdometryReading
from robot_daemon.hardware import roboteq
from robot_daemon.hardware.config import BatteryConfig, MotorsConfig
from robot_daemon.hardware.driver_thread import DriverThread

logger = logging.getLogger(__name__)

Clock = Callable[[], float]
SerialFactory = Callable[..., Any]


class NoReply(Exception):
    """The controller did not answer in time."""


class RoboteqDriver(DriverThread):
    """Differential drive on a RoboteQ controller; see the module docstring."""

    THREAD_NAME = "roboteq-driver"

    REPLY_TIMEOUT = 0.2  # [s]
    BATTERY_PERIOD = 1.0  # [s]
    MAX_SILENT_EXCHANGES = 3
    ZERO_FIRST_FRACTION = 0.8  # of the watchdog period

    def __init__(
        self,
        config: MotorsConfig,
        battery: BatteryConfig | None = None,
        clock: Clock = time.monotonic,
        serial_factory: SerialFactory = serial.Serial,
    ) -> None:
        work = ("commands", "clamped", "zero_first", "odometry")
        faults = ("malformed", "nacks", "timeouts", "disconnects")
        super().__init__(f"motors {config.port}", (*work, *faults, "connects"))
        self.config = config
        self.battery_config = battery or BatteryConfig()
        self.geometry = config  # the drive's kinematics
        self.clock = clock
        self.serial_factory = serial_factory
        self.odometry_model = roboteq.WheelOdometry(
            self.geometry, config.left_sign, config.right_sign
        )
        self._wake = threading.Event()
        self._pending: tuple[float, float, float] | None = None  # (linear, angular, stamp)
        self._odometry: OdometryReading | None = None
        self._battery: BatteryReading | None = None
        self._faults = 0
        self._clamping = False
        self._last_bang: float | None = None
        self._rx = bytearray()

    # -- life cycle ---------------------------------------------------------------------------

    def _wake_up(self) -> None:
        self._wake.set()

    # -- daemon side --------------------------------------------------------------------------

    def set_cmd_vel(self, linear: float, angular: float) -> None:
        """Queue a body twist [m/s, rad/s]; the driver thread sends the newest one."""
        with self._lock:
            self._pending = (linear, angular, self.clock())
        self._wake.set()

    def odometry(self) -> OdometryReading | None:
        with self._lock:
            return self._odometry

    def battery(self) -> BatteryReading | None:
        with self._lock:
            return self._battery

    def status(self) -> DeviceStatus:
        with self._lock:
            counters = dict(self.counters)
            ok, message, faults = self._connected, self._message, self._faults
        if faults:
            ok = False
            message = f"{message}; faults: {', '.join(roboteq.fault_names(faults))}"
        return DeviceStatus("motors", ok, message, counters)

    # -- the thread ---------------------------------------------------------------------------

    def _run(self) -> None:
        port = None
        while not self._stop.is_set():
            try:
                port = self.serial_factory(
                    self.config.port,
                    self.config.baudrate,
                    bytesize=8,
                    parity="N",
                    stopbits=1,
                    timeout=0.02,
                    write_timeout=0.5,
                )
                self._setup(port)
                self._loop(port)
            except (serial.SerialException, OSError) as exc:
                self._count("disconnects")
                self._fail(f"serial error on {self.config.port}: {exc}; reconnecting")
            except NoReply as exc:
                self._fail(f"controller not answering ({exc}); reconnecting")
            finally:
                if port is not None:
                    if self._stop.is_set():
                        self._stop_motors(port)
                    with contextlib.suppress(serial.SerialException, OSError):
                        port.close()
                    port = None
            self._stop.wait(self.config.reconnect_delay)
        self._set_state(False, "closed")

    def _setup(self, port: Any) -> None:
        port.reset_input_buffer()
        self._rx.clear()
        port.write(roboteq.config_command("ECHOF", 1))
        # The answer to ECHOF may still be echoed; let it arrive, then discard it.
        deadline = self.clock() + 0.05
        while self.clock() < deadline:
            port.read(max(1, port.in_waiting))
        port.reset_input_buffer()
        self._rx.clear()
        port.write(roboteq.config_command("RWD", self.config.watchdog_ms))
        self._expect_acks(port, 1)
        self._send_wheels(port, 0, 0)  # zero first on every new connection
        self._count("zero_first")
        self.odometry_model.rebase()
        self._count("connects")
        message = f"RoboteQ on {self.config.port}, watchdog {self.config.watchdog_ms} ms"
        self._set_state(True, message)
        logger.info("motors: %s", message)

    def _loop(self, port: Any) -> None:
        period = 1.0 / self.config.poll_hz
        silent = 0
        next_battery = self.clock()
        while not self._stop.is_set():
            self._wake.wait(period)
            self._wake.clear()
            if self._stop.is_set():
                return
            try:
                self._send_pending(port)
                self._poll_counts(port)
                if self.clock() >= next_battery:
                    next_battery = self.clock() + self.BATTERY_PERIOD
                    self._poll_battery(port)
                silent = 0
            except NoReply:
                self._count("timeouts")
                silent += 1
                if silent >= self.MAX_SILENT_EXCHANGES:
                    raise

    # -- exchanges ----------------------------------------------------------------------------

    def _read_line(self, port: Any, deadline: float) -> bytes:
        while True:
            end = self._rx.find(b"\r")
            if end >= 0:
                line = bytes(self._rx[:end]).strip(b"\n ")
                del self._rx[: end + 1]
                if line:
                    return line
                continue
            if self.clock() > deadline:
                raise NoReply("reply timed out")
            chunk = port.read(max(1, port.in_waiting))
            if chunk:
                self._rx += chunk
                if len(self._rx) > 4096:
                    self._count("malformed")
                    self._rx.clear()

    def _expect_acks(self, port: Any, count: int) -> None:
        deadline = self.clock() + self.REPLY_TIMEOUT
        got = 0
        while got < count:
            line = self._read_line(port, deadline)
            if line == b"+":
                got += 1
            elif line == b"-":
                got += 1
                self._count("nacks")
                logger.warning("motors: controller refused a command (-)")
            else:
                self._count("malformed")

    def _query(self, port: Any, name: str) -> bytes:
        """Send ``?name`` and return the first well-formed ``name=...`` reply line."""
        port.write(roboteq.query(name))
        deadline = self.clock() + self.REPLY_TIMEOUT
        while True:
            line = self._read_line(port, deadline)
            if line == b"-":
                self._count("nacks")
                raise NoReply(f"?{name} refused")
            try:
                roboteq.parse_query_reply(line, name)
            except roboteq.RoboteqError:
                self._count("malformed")
                continue
            return line

    def _send_wheels(self, port: Any, left: int, right: int) -> None:
        kind = self.config.command
        ch_l, ch_r = self.config.left_channel, self.config.right_channel
        port.write(
            roboteq.motor_command(kind, ch_l, self.config.left_sign * left)
            + roboteq.motor_command(kind, ch_r, self.config.right_sign * right)
        )
        self._last_bang = self.clock()
        self._expect_acks(port, 2)

    def _send_pending(self, port: Any) -> None:
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is None:
            return
        linear, angular, stamp = pending
        now = self.clock()
        if (now - stamp) * 1000.0 > self.config.watchdog_ms:
            return  # stale (e.g. queued while disconnected)
        cmd = roboteq.twist_to_command(self.geometry, linear, angular, self.config.command)
        if cmd.clamped:
            self._count("clamped")
            if not self._clamping:
                logger.warning(
                    "motors: (%.2f m/s, %.2f rad/s) exceeds max_rpm %.0f; both wheels scaled "
                    "by %.2f",
                    linear,
                    angular,
                    self.geometry.max_rpm,
                    cmd.scale,
                )
        self._clamping = cmd.clamped
        silence = None if self._last_bang is None else now - self._last_bang
        may_have_tripped = (
            silence is None
            or silence * 1000.0 >= self.ZERO_FIRST_FRACTION * self.config.watchdog_ms
        )
        if may_have_tripped and (cmd.left or cmd.right):
            # Defuse the resume-previous-speed trap before commanding motion.
            self._send_wheels(port, 0, 0)
            self._count("zero_first")
        self._send_wheels(port, cmd.left, cmd.right)
        self._count("commands")

    def _poll_counts(self, port: Any) -> None:
        sent = self.clock()
        values = roboteq.parse_query_reply(self._query(port, "C"), "C")
        stamp = (sent + self.clock()) / 2.0
        if len(values) != 2:
            self._count("malformed")
            return
        left = values[self.config.left_channel - 1]
        right = values[self.config.right_channel - 1]
        state = self.odometry_model.update(left, right, stamp)
        with self._lock:
            self._odometry = state
            self.counters["odometry"] += 1

    def _poll_battery(self, port: Any) -> None:
        try:
            volts = roboteq.parse_voltages(self._query(port, "V"))
            amps = roboteq.parse_battery_current(self._query(port, "BA"))
            faults = roboteq.parse_fault_flags(self._query(port, "FF"))
        except roboteq.RoboteqError as exc:
            self._count("malformed")
            logger.warning("motors: unusable battery/fault reply: %s", exc)
            return
        b = self.battery_config
        soc = roboteq.state_of_charge(volts.battery, amps, b.cells, b.internal_resistance)
        reading = BatteryReading(self.clock(), volts.battery, amps, soc)
        with self._lock:
            if faults != self._faults and faults:
                logger.warning("motors: controller faults: %s", roboteq.fault_names(faults))
            self._faults = faults
            self._battery = reading

    def _stop_motors(self, port: Any) -> None:
        try:
            self._send_wheels(port, 0, 0)
        except (serial.SerialException, OSError, NoReply):
            logger.warning(
                "motors: could not confirm the stop command; the watchdog will stop them"
            )
