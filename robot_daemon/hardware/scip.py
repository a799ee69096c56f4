"""SCIP 2.0, the Hokuyo URG/UTM command protocol: pure encoding, sum check and frame parsing.

Reference: Hokuyo "URG Series Communication Protocol Specification SCIP 2.0" and the
UTM-30LX(-EW) protocol sheet; the facts used here are summarised in shared/FIELD_NOTES.md
("Devices"). No I/O in this module: the driver (`hokuyo_driver`) and the emulator
(`tests/robot_daemon/hardware/emulators/hokuyo_emulator.py`) both build on it, and it is tested without a serial port.

Framing. A command is two letters, parameters and LF. A reply is the echo of the command, a
status line (two characters and a sum, e.g. ``00P``; ``99b`` in streamed scans), then data lines
and an empty line, so every reply ends in ``LF LF``. Data lines carry at most 64 characters
followed by one sum character::

    sum(line) = chr((sum(line bytes) & 0x3F) + 0x30)

For ``KEY:VALUE;S`` lines (VV, PP, II) the sum covers ``KEY:VALUE`` only, not the ``;``.

Encoding. Values are big-endian groups of 6 bits, each offset by 0x30: 2 characters (12 bit,
MS/GS), 3 characters (18 bit, MD/GD ranges in mm), 4 characters (24 bit, timestamps in ms that
wrap every 2^24 ms = 4.66 h). Spec examples: 5432 mm = ``1Dh``; 16000000 ms = ``m2@0``.

Geometry (from PP, never constants): step ``s`` points at ``(s - AFRT) * 2 pi / ARES`` [rad]
(REP-103, counter-clockwise positive); the mirror turns at SCAN rpm, so a scan takes
``60 / SCAN`` s; the sensor's timestamp is taken when the beam passes the rear of the sensor
(step ``AFRT - ARES / 2``).

Only the host's side is here (commands out, replies parsed); the sensor's side (encoding
values, replies and scans) belongs to the emulator, a test double
(`tests/robot_daemon/hardware/emulators/scip_encoder.py`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

LF = b"\n"
DATA_LINE_CHARS = 64  # payload characters per data line (the sum and LF follow)
TIMESTAMP_CHARS = 4
TIMESTAMP_MODULUS = 1 << 24  # [ms] the sensor clock wraps here
STATUS_OK = "00"
STATUS_STREAM = "99"
STATUS_ALREADY_ON = "02"  # BM: the laser was already on
STATUS_NOT_DEFINED = "0E"  # the reply to "SCIP2.0" from a sensor already in SCIP 2.0


class ScipError(ValueError):
    """A SCIP reply that cannot be used; subclasses say why."""


class ScipChecksumError(ScipError):
    """A line's sum character does not match its contents."""


class ScipTruncatedError(ScipError):
    """A reply is shorter than its layout requires (a lost byte, line or the end of a scan)."""


class ScipStatusError(ScipError):
    """The sensor answered with an error status."""

    def __init__(self, command: str, status: str) -> None:
        super().__init__(f"SCIP {command}: sensor replied with status {status!r}")
        self.command = command
        self.status = status


# -- characters and numbers -------------------------------------------------------------------


def checksum(payload: bytes) -> int:
    """The sum character (as a byte value) of a line's payload: ``(sum & 0x3F) + 0x30``."""
    return (sum(payload) & 0x3F) + 0x30


def verify_line(line: bytes) -> bytes:
    """The payload of ``payload + sum``; raises `ScipChecksumError` if the sum is wrong."""
    if len(line) < 2:
        raise ScipTruncatedError(f"SCIP line {line!r} is too short to carry a sum")
    payload, got = line[:-1], line[-1]
    if checksum(payload) != got:
        raise ScipChecksumError(
            f"SCIP line {line!r}: sum {chr(got)!r}, expected {chr(checksum(payload))!r}"
        )
    return payload


def decode_value(data: bytes) -> int:
    """Decode one value of any width (2, 3 or 4 characters)."""
    value = 0
    for c in data:
        if not 0x30 <= c <= 0x6F:
            raise ScipError(f"byte 0x{c:02x} is not a SCIP data character")
        value = (value << 6) | (c - 0x30)
    return value


def decode_array(data: bytes, chars: int) -> npt.NDArray[np.int64]:
    """Decode concatenated ``chars``-character values (vectorised; the scan hot path)."""
    if len(data) % chars:
        raise ScipTruncatedError(f"{len(data)} data characters are not a multiple of {chars}")
    raw = np.frombuffer(data, dtype=np.uint8).astype(np.int64) - 0x30
    if raw.size and (raw.min() < 0 or raw.max() > 0x3F):
        raise ScipError("scan data holds a byte outside the SCIP character range 0x30..0x6F")
    groups = raw.reshape(-1, chars)
    weights = np.left_shift(1, 6 * np.arange(chars - 1, -1, -1, dtype=np.int64))
    return groups @ weights


# -- status and KEY:VALUE lines ---------------------------------------------------------------


def parse_status(line: bytes) -> str:
    """The two-character status of a status line (checks its sum).

    A sensor still in SCIP 1.1 answers ``SCIP2.0`` with the bare status ``0`` (no sum);
    that one-character form is returned as is.
    """
    if len(line) == 1:
        return line.decode("ascii")
    if len(line) != 3:
        raise ScipTruncatedError(f"SCIP status line {line!r} must be 2 characters and a sum")
    return verify_line(line).decode("ascii")


def parse_info_line(line: bytes) -> tuple[str, str]:
    """``KEY:VALUE;S`` -> (KEY, VALUE), checking the sum (which excludes the ``;``)."""
    if len(line) < 4 or line[-2:-1] != b";":
        raise ScipTruncatedError(f"SCIP info line {line!r} is not KEY:VALUE;sum")
    body = line[:-2]
    if checksum(body) != line[-1]:
        raise ScipChecksumError(
            f"SCIP info line {line!r}: sum {chr(line[-1])!r}, expected {chr(checksum(body))!r}"
        )
    key, sep, value = body.decode("ascii", errors="replace").partition(":")
    if not sep:
        raise ScipError(f"SCIP info line {line!r} has no ':'")
    return key, value


# -- replies ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Reply:
    """One reply: the echoed command, its status, and the lines between them and the end."""

    echo: bytes
    status: str
    lines: tuple[bytes, ...]


def split_frame(frame: bytes) -> list[bytes]:
    """The lines of one reply, without the LFs and the terminating empty line."""
    if frame.endswith(b"\n\n"):
        frame = frame[:-2]
    elif frame.endswith(b"\n"):
        frame = frame[:-1]
    return frame.split(LF)


def parse_reply(frame: bytes) -> Reply:
    """Echo, status and body of a reply (``frame`` ends at its empty line)."""
    lines = split_frame(frame)
    if len(lines) < 2:
        raise ScipTruncatedError(f"SCIP reply {frame[:40]!r} has no status line")
    return Reply(lines[0], parse_status(lines[1]), tuple(lines[2:]))


def parse_info(reply: Reply, command: str) -> dict[str, str]:
    """The KEY:VALUE body of a VV, PP or II reply; raises on an error status or a bad sum."""
    if reply.status != STATUS_OK:
        raise ScipStatusError(command, reply.status)
    return dict(parse_info_line(line) for line in reply.lines if line)


# -- sensor parameters (PP) -------------------------------------------------------------------


@dataclass(frozen=True)
class SensorParameters:
    """The scan geometry a sensor reports in its PP reply."""

    model: str
    dmin: int  # [mm]
    dmax: int  # [mm]
    ares: int  # steps per full turn
    amin: int  # first measurable step
    amax: int  # last measurable step
    afrt: int  # step pointing forward
    scan_rpm: int

    def __post_init__(self) -> None:
        if not (0 <= self.dmin < self.dmax and self.ares > 0 and self.scan_rpm > 0):
            raise ScipError(f"PP parameters are inconsistent: {self}")
        if not 0 <= self.amin <= self.afrt <= self.amax < 10_000:
            raise ScipError(f"PP needs 0 <= AMIN <= AFRT <= AMAX < 10000: {self}")

    @classmethod
    def from_info(cls, info: dict[str, str]) -> SensorParameters:
        """Build from a parsed PP reply; names the missing or non-numeric key."""
        values: list[int] = []
        for key in ("DMIN", "DMAX", "ARES", "AMIN", "AMAX", "AFRT", "SCAN"):  # the fields' order
            text = info.get(key)
            if text is None:
                raise ScipError(f"PP reply lacks {key} (got keys {sorted(info)})")
            try:
                values.append(int(text))
            except ValueError:
                raise ScipError(f"PP {key}:{text!r} is not an integer") from None
        return cls(info.get("MODL", "?"), *values)

    @property
    def steps(self) -> int:
        """Beams in a full AMIN..AMAX scan (1081 on the UTM-30LX)."""
        return self.amax - self.amin + 1

    @property
    def angle_increment(self) -> float:
        """Angle between steps [rad] (2 pi / ARES)."""
        return math.tau / self.ares

    def angle(self, step: int) -> float:
        """Direction of a step [rad]: ``(step - AFRT) * 2 pi / ARES``."""
        return (step - self.afrt) * self.angle_increment

    @property
    def scan_period(self) -> float:
        """Time for one turn of the mirror [s] (60 / SCAN)."""
        return 60.0 / self.scan_rpm


# -- commands and streamed scans --------------------------------------------------------------


def md_command(start: int, end: int, cluster: int = 0, interval: int = 0, scans: int = 0) -> bytes:
    """``MDssssEEEEccirr`` + LF: stream ``scans`` scans (0 = until QT) of steps start..end."""
    if not (0 <= start <= end <= 9999 and 0 <= cluster <= 99 and 0 <= interval <= 9):
        raise ValueError("MD parameters out of range")
    if not 0 <= scans <= 99:
        raise ValueError("MD scan count must be in 0..99")
    return f"MD{start:04d}{end:04d}{cluster:02d}{interval:01d}{scans:02d}\n".encode("ascii")


@dataclass(frozen=True)
class MdRequest:
    """The parameters of an MD/MS echo or command (the driver streams: it never sends GD)."""

    command: str
    start: int
    end: int
    cluster: int
    interval: int
    scans: int


def parse_md_request(line: bytes) -> MdRequest:
    """Parse ``MDssssEEEEccirr`` (MD/MS) without the LF."""
    text = line.decode("ascii", errors="replace")
    fields = (text[2:6], text[6:10], text[10:12], text[12:13], text[13:15])
    if text[:2] not in ("MD", "MS") or len(text) != 15 or not all(f.isdigit() for f in fields):
        raise ScipError(f"{text!r} is not an MD/MS request")
    return MdRequest(text[:2], *(int(f) for f in fields))


@dataclass(frozen=True)
class ScanFrame:
    """One decoded scan: the sensor timestamp [ms, 24 bit] and the ranges [mm]."""

    timestamp_ms: int
    ranges_mm: npt.NDArray[np.int64]
    remaining: int  # scans still to come (0 for an unlimited MD)


def parse_scan_frame(lines: list[bytes], steps: int, chars: int = 3) -> ScanFrame:
    """Decode a streamed MD scan given as lines (echo, status, timestamp, data).

    The layout is checked before the sums, so a line that lost bytes raises
    `ScipTruncatedError` and a corrupted byte `ScipChecksumError`; either way nothing of the
    scan is returned.
    """
    if len(lines) < 3:
        raise ScipTruncatedError(f"scan reply has {len(lines)} lines, needs at least 3")
    echo = lines[0]
    request = parse_md_request(echo)
    status = parse_status(lines[1])
    if status != STATUS_STREAM:
        raise ScipStatusError(request.command, status)
    if len(lines[2]) != TIMESTAMP_CHARS + 1:
        raise ScipTruncatedError(f"timestamp line {lines[2]!r} must be 4 characters and a sum")
    payload_len = steps * chars
    n_lines = -(-payload_len // DATA_LINE_CHARS)
    data = lines[3:]
    if len(data) != n_lines:
        raise ScipTruncatedError(f"scan has {len(data)} data lines, expected {n_lines}")
    for i, line in enumerate(data):
        want = min(DATA_LINE_CHARS, payload_len - i * DATA_LINE_CHARS) + 1
        if len(line) != want:
            raise ScipTruncatedError(f"data line {i} has {len(line)} bytes, expected {want}")
    timestamp = decode_value(verify_line(lines[2]))
    payload = b"".join(verify_line(line) for line in data)
    return ScanFrame(timestamp, decode_array(payload, chars), request.scans)


# -- timestamps -------------------------------------------------------------------------------


class ScanClock:
    """Maps 24-bit sensor timestamps [ms] to host time [s] for the first beam of each scan.

    The counter is unwrapped (a jump back by more than half the range is a wrap, 2^24 ms).
    The offset between the clocks is the minimum of ``t_received - t_sensor`` over a sliding
    window (default 400 scans, 10 s at 40 Hz): the least-delayed frame bounds the transfer
    latency, and the window follows the drift between the two crystals. Since the frame is
    sent after the last step, the least delay is measured from the last step, so

        t_first_beam = t_sensor + min(t_rx - t_sensor) - (AMAX - AMIN) / ARES * T_scan

    and the rear-of-scan reference of the timestamp cancels out (it matters only for a
    clock sync through the TM command, not used here). The remaining bias is the shortest
    USB transfer time (about 1 ms); stamps never lie after the reception.
    """

    def __init__(self, scan_duration: float, window: int = 400) -> None:
        self.scan_duration = scan_duration  # [s] first to last measured step
        self._window = window
        self._last_raw: int | None = None
        self._wraps = 0
        self._samples: deque[tuple[int, float]] = deque()  # (index, offset) increasing offsets
        self._index = 0

    def unwrap(self, raw_ms: int) -> int:
        """The 24-bit timestamp extended with the number of wraps seen [ms]."""
        if self._last_raw is not None and raw_ms < self._last_raw - TIMESTAMP_MODULUS // 2:
            self._wraps += 1
        self._last_raw = raw_ms
        return raw_ms + self._wraps * TIMESTAMP_MODULUS

    def stamp(self, raw_ms: int, received: float) -> float:
        """Host time [s] of the first beam of the scan with sensor time ``raw_ms``."""
        sensor = self.unwrap(raw_ms) / 1000.0
        offset = received - sensor
        self._index += 1
        # Sliding-window minimum with a monotonic deque (amortised O(1)).
        while self._samples and self._samples[-1][1] >= offset:
            self._samples.pop()
        self._samples.append((self._index, offset))
        while self._samples[0][0] <= self._index - self._window:
            self._samples.popleft()
        return sensor + self._samples[0][1] - self.scan_duration
