"""Hokuyo UTM-30LX driver (thesis §4.1.5): SCIP 2.0 over USB with pyserial, on its own thread.

Start-up (`_handshake`): ``QT`` (stops a stream left running by a previous process and drains
it), ``SCIP2.0`` (answered ``0`` by a sensor in SCIP 1.1, ``0E`` by one already in 2.0), ``VV``,
``PP`` (the scan geometry: AMIN, AMAX, ARES, AFRT, SCAN rpm, DMIN/DMAX; never constants), ``II``,
``BM`` (laser on), then ``MD<AMIN><AMAX>00000`` streams every scan with 3-character ranges until
``QT``. On `close`: ``QT`` and ``RS``.

Every line's sum is checked; a scan with a bad sum, a truncated line, a wrong status or a
missing end is dropped whole and counted, never half-used. No byte for ``stall_timeout``
(the UTM-30LX sends 40 scans a second) counts as a stall; a stall, a serial error (the USB
cable pulled) or a failed handshake closes the port and the driver reconnects every
``reconnect_delay`` seconds. Counters and the reason of the last failure are in `status`.

Why a thread: pyserial reads block; a thread that owns the port keeps the daemon's control
loop free of I/O waits, reconnection delays and handshakes (hundreds of ms). It hands the
newest complete scan over under a lock with a sequence number, so the reader gets each scan
at most once and never a partial one. Scans are stamped on the host clock (`scip.ScanClock`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import serial

from interbot_core.laser_scan import LaserScan
from robot_daemon.backend import DeviceStatus
from robot_daemon.hardware import scip
from robot_daemon.hardware.config import LaserConfig
from robot_daemon.hardware.driver_thread import DriverThread

logger = logging.getLogger(__name__)

Clock = Callable[[], float]
SerialFactory = Callable[..., Any]


# The counter a scan dropped for each kind of SCIP error goes to (any other: "malformed").
DROPPED_AS = {
    scip.ScipChecksumError: "bad_sum",
    scip.ScipTruncatedError: "truncated",
    scip.ScipStatusError: "bad_status",
}


class LaserStalled(Exception):
    """No byte arrived for the stall timeout."""


class HandshakeError(Exception):
    """The sensor did not answer the start-up sequence as the spec says."""


class _FrameReader:
    """Splits the byte stream into replies (each ends with an empty line)."""

    MAX_BUFFER = 1 << 16

    def __init__(self, port: Any, clock: Clock, stall_timeout: float) -> None:
        self.port = port
        self.clock = clock
        self.stall_timeout = stall_timeout
        self.buffer = bytearray()
        self.last_rx = clock()

    def next_frame(self, timeout: float | None = None) -> tuple[bytes, float]:
        """The next reply and the host time its last bytes arrived.

        Raises `LaserStalled` after ``stall_timeout`` without a byte, or ``TimeoutError``
        when ``timeout`` passes without a complete reply.
        """
        start = self.clock()
        while True:
            end = self.buffer.find(b"\n\n")
            if end >= 0:
                frame = bytes(self.buffer[: end + 2])
                del self.buffer[: end + 2]
                return frame, self.last_rx
            now = self.clock()
            if timeout is not None and now - start > timeout:
                raise TimeoutError("no complete SCIP reply")
            if now - self.last_rx > self.stall_timeout:
                raise LaserStalled(f"no data for {now - self.last_rx:.2f} s")
            chunk = self.port.read(max(1, self.port.in_waiting))
            if chunk:
                self.last_rx = self.clock()
                self.buffer += chunk
                if len(self.buffer) > self.MAX_BUFFER:
                    del self.buffer[: -self.MAX_BUFFER // 2]


class HokuyoDriver(DriverThread):
    """Streams scans from a UTM-30LX; see the module docstring."""

    THREAD_NAME = "hokuyo-driver"

    def __init__(
        self,
        config: LaserConfig,
        clock: Clock = time.monotonic,
        serial_factory: SerialFactory = serial.Serial,
        reply_timeout: float = 0.5,
    ) -> None:
        failures = ("malformed", "stalls", "disconnects", "handshake_failures")
        super().__init__(
            f"laser {config.port}", ("scans", *DROPPED_AS.values(), *failures, "connects")
        )
        self.config = config
        self.reply_timeout = reply_timeout  # [s] for each handshake reply
        self.clock = clock
        self.serial_factory = serial_factory
        self.params: scip.SensorParameters | None = None
        self.version: dict[str, str] = {}
        self._latest: LaserScan | None = None
        self._seq = 0
        self._last_scan_time: float | None = None

    # -- results ------------------------------------------------------------------------------

    def latest(self) -> tuple[int, LaserScan | None]:
        """(sequence number, newest complete scan); the number grows by one per scan."""
        with self._lock:
            return self._seq, self._latest

    def status(self) -> DeviceStatus:
        with self._lock:
            counters = dict(self.counters)
            connected, message, last = self._connected, self._message, self._last_scan_time
        stale = last is None or self.clock() - last > max(0.5, 4 * self.config.stall_timeout)
        ok = connected and not stale
        if connected and stale:
            message = f"{message}; no scan received recently"
        return DeviceStatus("laser", ok, message, counters)

    # -- the thread ---------------------------------------------------------------------------

    def _run(self) -> None:
        port = None
        while not self._stop.is_set():
            try:
                port = self.serial_factory(
                    self.config.port, self.config.baudrate, timeout=0.02, write_timeout=0.5
                )
                port.reset_input_buffer()
                reader = _FrameReader(port, self.clock, self.config.stall_timeout)
                self._handshake(port, reader)
                self._count("connects")
                self._stream(port, reader)
            except LaserStalled as exc:
                self._count("stalls")
                self._fail(f"stalled ({exc}); reconnecting")
            except (serial.SerialException, OSError) as exc:
                self._count("disconnects")
                self._fail(f"serial error on {self.config.port}: {exc}; reconnecting")
            except (HandshakeError, TimeoutError, scip.ScipError) as exc:
                self._count("handshake_failures")
                self._fail(f"handshake failed: {exc}; reconnecting")
            finally:
                if port is not None:
                    if self._stop.is_set():
                        self._shutdown(port)
                    with contextlib.suppress(serial.SerialException, OSError):
                        port.close()
                    port = None
            self._stop.wait(self.config.reconnect_delay)
        self._set_state(False, "closed")

    def _command(self, port: Any, reader: _FrameReader, command: bytes) -> scip.Reply:
        """Send ``command`` and return its reply, skipping other frames (e.g. old scans)."""
        port.write(command)
        echo = command.rstrip(b"\n")
        deadline = self.clock() + self.reply_timeout
        while True:
            remaining = deadline - self.clock()
            if remaining <= 0:
                raise TimeoutError(f"no reply to {echo.decode()}")
            frame, _ = reader.next_frame(timeout=remaining)
            lines = scip.split_frame(frame)
            if lines and lines[0] == echo:
                return scip.parse_reply(frame)

    def _handshake(self, port: Any, reader: _FrameReader) -> None:
        self._set_state(False, f"connecting to {self.config.port}")
        # QT first: a stream left running by a crashed process floods the input until QT.
        self._command(port, reader, b"QT\n")
        reply = self._command(port, reader, b"SCIP2.0\n")
        if reply.status not in ("0", scip.STATUS_NOT_DEFINED):
            raise HandshakeError(f"SCIP2.0 answered {reply.status!r}")
        self.version = scip.parse_info(self._command(port, reader, b"VV\n"), "VV")
        self.params = scip.SensorParameters.from_info(
            scip.parse_info(self._command(port, reader, b"PP\n"), "PP")
        )
        scip.parse_info(self._command(port, reader, b"II\n"), "II")  # its status and sums
        reply = self._command(port, reader, b"BM\n")
        if reply.status not in (scip.STATUS_OK, scip.STATUS_ALREADY_ON):
            raise scip.ScipStatusError("BM", reply.status)
        p = self.params
        reply = self._command(port, reader, scip.md_command(p.amin, p.amax))
        if reply.status != scip.STATUS_OK:
            raise scip.ScipStatusError("MD", reply.status)
        logger.info(
            "laser %s: %s (%s), %d steps of %.3f deg, %.1f Hz, %.3f-%.1f m",
            self.config.port,
            p.model,
            self.version.get("FIRM", "?"),
            p.steps,
            math.degrees(p.angle_increment),
            p.scan_rpm / 60.0,
            p.dmin / 1000.0,
            p.dmax / 1000.0,
        )

    def _stream(self, port: Any, reader: _FrameReader) -> None:
        p = self.params
        assert p is not None
        clock = scip.ScanClock(scan_duration=(p.amax - p.amin) / p.ares * p.scan_period)
        self._set_state(True, f"streaming {p.model} on {self.config.port}")
        while not self._stop.is_set():
            frame, received = reader.next_frame()
            scan = self._decode(frame, received, clock)
            if scan is not None:
                with self._lock:
                    self._latest = scan
                    self._seq += 1
                    self.counters["scans"] += 1
                    self._last_scan_time = self.clock()

    def _decode(self, frame: bytes, received: float, clock: scip.ScanClock) -> LaserScan | None:
        p = self.params
        assert p is not None
        lines = scip.split_frame(frame)
        if not lines or not lines[0].startswith(b"MD"):
            self._count("malformed")
            return None
        try:
            decoded = scip.parse_scan_frame(lines, p.steps)
        except scip.ScipError as exc:
            self._count(DROPPED_AS.get(type(exc), "malformed"))
            return None
        mm = decoded.ranges_mm
        ranges = mm.astype(np.float32) / np.float32(1000.0)
        ranges[mm < p.dmin] = np.nan  # error codes (no echo, too close, ...)
        ranges[mm > p.dmax] = np.inf
        return LaserScan(
            stamp=clock.stamp(decoded.timestamp_ms, received),
            angle_min=p.angle(p.amin),
            angle_increment=p.angle_increment,
            range_min=p.dmin / 1000.0,
            range_max=p.dmax / 1000.0,
            ranges=ranges,
        )

    def _shutdown(self, port: Any) -> None:
        """QT (stop the stream, laser off) and RS (reset) before releasing the port."""
        for command in (b"QT\n", b"RS\n"):
            try:
                port.write(command)
                port.flush()
            except (serial.SerialException, OSError):
                return
        # Give the sensor a moment to read them before the port closes.
        deadline = self.clock() + 0.05
        while self.clock() < deadline:
            try:
                if not port.read(max(1, port.in_waiting)):
                    break
            except (serial.SerialException, OSError):
                return
