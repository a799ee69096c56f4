"""A Hokuyo UTM-30LX emulator answering SCIP 2.0 on a pseudo-terminal (from the spec).

Implements SCIP2.0 (answers ``0E``: already in SCIP 2.0), VV, PP, II, BM, QT, RS, GD and MD
(start, end, cluster, skip interval and scan count). The mirror turns at SCAN rpm from the
moment the emulator starts; scan k has its timestamp when the beam passes the rear
(``clock_start_ms + k T`` in ms, wrapping at 2^24) and is sent when its last step has been
measured, like the sensor. Ranges come from a profile: a fixed array of 1081 mm values or a
function of the scan index (default: a 8 m x 5 m room around the sensor).

Fault injection: `inject_bad_sum` (one data byte changed, its sum kept), `inject_truncated`
(bytes cut out of a data line), `stall` (silence, input ignored), `unplug` (the pty pair
is destroyed, recreated behind the same link later, device reset).

Run stand-alone for the daemon::

    python -m tests.robot_daemon.hardware.emulators.hokuyo_emulator --pty [--link /tmp/ttyHOKUYO]

prints the port to open and serves until Ctrl-C.
"""

from __future__ import annotations

import argparse
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robot_daemon.hardware import scip
from tests.robot_daemon.hardware.emulators import scip_encoder
from tests.robot_daemon.hardware.emulators.pty_port import EmulatorThread, serve_forever

logger = logging.getLogger(__name__)

#: The real UTM-30LX-EW PP reply (shared/FIELD_NOTES.md), in the sensor's order.
UTM30LX_PP: dict[str, str] = {
    "MODL": "UTM-30LX-EW",
    "DMIN": "23",
    "DMAX": "60000",
    "ARES": "1440",
    "AMIN": "0",
    "AMAX": "1080",
    "AFRT": "540",
    "SCAN": "2400",
}
UTM30LX_VV: dict[str, str] = {
    "VEND": "Hokuyo Automatic Co.,Ltd.",
    "PROD": "SOKUIKI Sensor TOP-URG UTM-30LX-EW",
    "FIRM": "1.20.00(26/Jan./2012)",
    "PROT": "SCIP 2.0",
    "SERI": "H0000000",
}

RangeProfile = npt.ArrayLike | Callable[[int], npt.ArrayLike]


def room_profile(
    params: scip.SensorParameters, half_x: float = 4.0, half_y: float = 2.5
) -> npt.NDArray[np.int64]:
    """Ranges [mm] from the centre of a ``2 half_x`` x ``2 half_y`` m room, per step."""
    steps = np.arange(params.amin, params.amax + 1)
    a = (steps - params.afrt) * params.angle_increment
    with np.errstate(divide="ignore"):
        r = np.minimum(half_x / np.abs(np.cos(a)), half_y / np.abs(np.sin(a)))
    mm: npt.NDArray[np.int64] = np.clip(np.round(r * 1000.0), params.dmin, params.dmax).astype(
        np.int64
    )
    return mm


class HokuyoEmulator(EmulatorThread):
    """SCIP 2.0 device on a pty; see the module docstring."""

    name = "hokuyo-emulator"

    def __init__(
        self,
        ranges_mm: RangeProfile | None = None,
        link: Path | None = None,
        clock_start_ms: int = 0,
        pp: dict[str, str] | None = None,
    ) -> None:
        super().__init__(link)
        self.pp = dict(pp or UTM30LX_PP)
        self.params = scip.SensorParameters.from_info(self.pp)
        self._profile: RangeProfile = room_profile(self.params) if ranges_mm is None else ranges_mm
        self.clock_start_ms = clock_start_ms
        self._rx = bytearray()
        self._laser_on = False
        self._md: scip.MdRequest | None = None
        self._md_remaining = 0
        self._next_scan = 0  # index of the next scan to consider for MD
        self._t0 = time.monotonic()  # the mirror turns from power-on
        self._bad_sum = 0
        self._truncated = 0
        self._stall_until = 0.0
        self.commands: list[str] = []
        self.scans_sent = 0
        #: (scan index, host time of the first beam [s], sensor timestamp [ms]) of sent scans.
        self.sent: deque[tuple[int, float, int]] = deque(maxlen=1000)
        self.scan_sent = threading.Condition(self._lock)

    # -- fault injection ----------------------------------------------------------------------

    def inject_bad_sum(self, count: int = 1) -> None:
        with self._lock:
            self._bad_sum += count

    def inject_truncated(self, count: int = 1) -> None:
        with self._lock:
            self._truncated += count

    def stall(self, seconds: float) -> None:
        """Send nothing and ignore all input for ``seconds`` (a hung firmware)."""
        with self._lock:
            self._stall_until = time.monotonic() + seconds

    @property
    def streaming(self) -> bool:
        with self._lock:
            return self._md is not None

    def wait_scans(self, count: int, timeout: float) -> bool:
        """Block until ``count`` more scans have been sent (False on timeout)."""
        with self.scan_sent:
            target = self.scans_sent + count
            return self.scan_sent.wait_for(lambda: self.scans_sent >= target, timeout)

    # -- timing -------------------------------------------------------------------------------

    def _rear_time(self, k: int) -> float:
        return self._t0 + k * self.params.scan_period

    def _timestamp_ms(self, k: int) -> int:
        ms = self.clock_start_ms + round(k * self.params.scan_period * 1000.0)
        return ms % scip.TIMESTAMP_MODULUS

    def _scan_index_after(self, now: float) -> int:
        return max(0, math.ceil((now - self._t0) / self.params.scan_period))

    def ranges_for(self, k: int) -> npt.NDArray[np.int64]:
        """The profile's ranges [mm] for scan ``k`` (all AMIN..AMAX steps)."""
        profile = self._profile(k) if callable(self._profile) else self._profile
        ranges = np.asarray(profile, dtype=np.int64)
        if ranges.shape != (self.params.steps,):
            raise ValueError(f"range profile must have {self.params.steps} values")
        return ranges

    def _select(self, ranges: npt.NDArray[np.int64], req: scip.MdRequest) -> npt.NDArray[np.int64]:
        part = ranges[req.start - self.params.amin : req.end - self.params.amin + 1]
        c = max(req.cluster, 1)
        if c == 1:
            return part
        pad = (-part.size) % c
        grouped = np.concatenate([part, np.full(pad, part.max())]).reshape(-1, c)
        nearest: npt.NDArray[np.int64] = grouped.min(axis=1)  # a cluster reports its nearest
        return nearest

    # -- EmulatorThread -----------------------------------------------------------------------

    def _on_replug(self, now: float) -> None:
        self._rx.clear()
        self._laser_on = False
        self._md = None

    def _on_bytes(self, data: bytes, now: float) -> None:
        if now < self._stall_until:
            return
        self._rx += data
        while True:
            # Commands end with LF (or CR); tolerate CR LF.
            ends = [i for i in (self._rx.find(b"\n"), self._rx.find(b"\r")) if i >= 0]
            if not ends:
                break
            end = min(ends)
            line = bytes(self._rx[:end])
            del self._rx[: end + 1]
            if line:
                self._handle(line, now)
        if len(self._rx) > 256:
            self._rx.clear()

    def _tick(self, now: float) -> None:
        if now < self._stall_until or self._md is None:
            return
        # Scans missed while stalled or blocked are skipped, as the sensor does not queue them.
        latest = math.floor(
            (now - self._rear_time(0) - scip_encoder.step_delay(self.params, self.params.amax))
            / self.params.scan_period
        )
        k = max(self._next_scan, latest)
        send_at = self._rear_time(k) + scip_encoder.step_delay(self.params, self.params.amax)
        if now < send_at:
            return
        req = self._md
        self._next_scan = k + 1 + req.interval
        if req.scans:
            self._md_remaining -= 1
        remaining = self._md_remaining if req.scans else 0
        echo = scip.md_command(req.start, req.end, req.cluster, req.interval, remaining)[:-1]
        frame = scip_encoder.encode_scan_frame(
            echo, scip.STATUS_STREAM, self._timestamp_ms(k), self._select(self.ranges_for(k), req)
        )
        self._write(self._corrupt(frame))
        self.sent.append(
            (
                k,
                self._rear_time(k) + scip_encoder.step_delay(self.params, self.params.amin),
                self._timestamp_ms(k),
            )
        )
        self.scans_sent += 1
        self.scan_sent.notify_all()
        if req.scans and self._md_remaining <= 0:
            self._md = None

    def _corrupt(self, frame: bytes) -> bytes:
        lines = frame.split(b"\n")
        if self._bad_sum:
            self._bad_sum -= 1
            line = bytearray(lines[5])  # a full data line
            line[10] = 0x30 + ((line[10] - 0x30 + 1) % 64)
            lines[5] = bytes(line)
        elif self._truncated:
            self._truncated -= 1
            lines[7] = lines[7][:20] + lines[7][-1:]
        return b"\n".join(lines)

    def _write(self, data: bytes) -> None:
        self.pty.write(data)

    # -- commands -----------------------------------------------------------------------------

    def _reply(self, echo: bytes, status: str, body: list[bytes] | None = None) -> None:
        parts = [echo, scip_encoder.status_line(status), *(body or [])]
        self._write(b"\n".join(parts) + b"\n\n")

    def _handle(self, line: bytes, now: float) -> None:
        text = line.decode("ascii", errors="replace")
        self.commands.append(text)
        cmd = text[:2]
        if text == "SCIP2.0":
            self._reply(line, scip.STATUS_NOT_DEFINED)  # already SCIP 2.0: "0Ee"
        elif text in ("VV", "PP"):
            info = UTM30LX_VV if text == "VV" else self.pp
            self._reply(
                line, scip.STATUS_OK, [scip_encoder.info_line(k, v) for k, v in info.items()]
            )
        elif text == "II":
            ts = scip_encoder.encode_value(
                self._timestamp_ms(self._scan_index_after(now)), 4
            ).decode()
            info = {
                "MODL": self.pp["MODL"],
                "LASR": "ON" if self._laser_on else "OFF",
                "SCSP": f"Initial({self.params.scan_rpm})[rpm]",
                "MESM": "Measuring by Normal Mode",
                "SBPS": "USB only",
                "TIME": ts,
                "STAT": "Stable 000 no error.",
            }
            self._reply(
                line, scip.STATUS_OK, [scip_encoder.info_line(k, v) for k, v in info.items()]
            )
        elif text == "BM":
            status = scip.STATUS_ALREADY_ON if self._laser_on else scip.STATUS_OK
            self._laser_on = True
            self._reply(line, status)
        elif text in ("QT", "RS"):
            self._md = None
            self._laser_on = False
            self._reply(line, scip.STATUS_OK)
        elif cmd in ("MD", "GD"):
            self._handle_measurement(line, now)
        else:
            self._reply(line, scip.STATUS_NOT_DEFINED)

    def _handle_measurement(self, line: bytes, now: float) -> None:
        try:
            req = _parse_gd_request(line) if line[:2] == b"GD" else scip.parse_md_request(line)
        except (scip.ScipError, ValueError):
            self._reply(line, "0C")  # malformed parameters
            return
        p = self.params
        if not (p.amin <= req.start <= req.end <= p.amax):
            self._reply(line, "04")  # step out of range
            return
        if req.command == "GD":
            if not self._laser_on:
                self._reply(line, "10")  # laser off
                return
            k = max(self._scan_index_after(now) - 1, 0)
            self._write(
                scip_encoder.encode_scan_frame(
                    line,
                    scip.STATUS_OK,
                    self._timestamp_ms(k),
                    self._select(self.ranges_for(k), req),
                )
            )
            return
        self._laser_on = True
        self._md = req
        self._md_remaining = req.scans
        self._next_scan = self._scan_index_after(now)
        self._reply(line, scip.STATUS_OK)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Hokuyo UTM-30LX (SCIP 2.0) emulator on a pty")
    parser.add_argument("--pty", action="store_true", help="serve on a new pseudo-terminal")
    parser.add_argument("--link", type=Path, help="also make this symlink to the pty")
    args = parser.parse_args(argv)
    if not args.pty:
        parser.error("only --pty is supported")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    emulator = HokuyoEmulator(link=args.link)
    serve_forever(emulator)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


def _parse_gd_request(line: bytes) -> scip.MdRequest:
    """``GDssssEEEEcc``: one scan (the driver only streams, so the product parses MD only)."""
    if len(line) != 12:
        raise ValueError(f"{line!r} is not a GD request")
    return scip.MdRequest("GD", int(line[2:6]), int(line[6:10]), int(line[10:12]), 0, 1)
