"""The sensor's side of SCIP 2.0, for the Hokuyo emulator: values, lines and scan replies encoded
as a UTM-30LX sends them (the inverse of what `robot_daemon.hardware.scip` parses).

A test double's helper (issue 13: no test doubles in product packages); the host's side, its
constants and its parsing stay in `robot_daemon.hardware.scip`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_daemon.hardware.scip import (
    DATA_LINE_CHARS,
    TIMESTAMP_MODULUS,
    SensorParameters,
    checksum,
)


def with_sum(payload: bytes) -> bytes:
    """``payload`` followed by its sum character (no LF)."""
    return payload + bytes((checksum(payload),))


def encode_value(value: int, chars: int) -> bytes:
    """``value`` in ``chars`` 6-bit characters (0x30 offset, big-endian)."""
    if not 0 <= value < 1 << (6 * chars):
        raise ValueError(f"{value} does not fit in {chars} SCIP characters")
    return bytes(((value >> (6 * (chars - 1 - i))) & 0x3F) + 0x30 for i in range(chars))


def encode_array(values: npt.ArrayLike, chars: int) -> bytes:
    """Encode values as concatenated ``chars``-character groups (inverse of `decode_array`)."""
    v = np.asarray(values, dtype=np.int64)
    if v.size and (v.min() < 0 or v.max() >= 1 << (6 * chars)):
        raise ValueError(f"values do not fit in {chars} SCIP characters")
    shifts = 6 * np.arange(chars - 1, -1, -1, dtype=np.int64)
    out = ((v[:, None] >> shifts) & 0x3F) + 0x30
    return out.astype(np.uint8).tobytes()


def data_lines(payload: bytes) -> list[bytes]:
    """Split a data block into lines of <= 64 characters, each followed by its sum."""
    step = DATA_LINE_CHARS
    return [with_sum(payload[i : i + step]) for i in range(0, len(payload), step)]


def status_line(status: str) -> bytes:
    """``00`` -> ``b"00P"``."""
    return with_sum(status.encode("ascii"))


def info_line(key: str, value: str) -> bytes:
    """``KEY:VALUE;S`` with the sum over ``KEY:VALUE`` (the ``;`` is excluded)."""
    body = f"{key}:{value}".encode("ascii")
    return body + b";" + bytes((checksum(body),))


def step_delay(params: SensorParameters, step: float) -> float:
    """Time from the timestamp (beam at the rear, step ``AFRT - ARES / 2``) to the measurement
    of ``step`` [s]."""
    rear_step = params.afrt - params.ares / 2
    return ((step - rear_step) % params.ares) / params.ares * params.scan_period


def encode_scan_frame(
    echo: bytes, status: str, timestamp_ms: int, ranges_mm: npt.ArrayLike, chars: int = 3
) -> bytes:
    """The bytes of one scan reply (the emulator's side of `scip.parse_scan_frame`)."""
    parts = [echo, status_line(status), with_sum(encode_value(timestamp_ms % TIMESTAMP_MODULUS, 4))]
    parts += data_lines(encode_array(ranges_mm, chars))
    return b"\n".join(parts) + b"\n\n"
