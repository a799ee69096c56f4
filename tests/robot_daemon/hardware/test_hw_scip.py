"""SCIP 2.0 encoding, sums and framing against the spec examples (shared/FIELD_NOTES.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_daemon.hardware import scip
from tests.robot_daemon.hardware.emulators import scip_encoder

REAL_PP_LINES = [
    b"MODL:UTM-30LX-EW;I",
    b"DMIN:23;7",
    b"DMAX:60000;J",
    b"ARES:1440;^",
    b"AMIN:0;?",
    b"AMAX:1080;Z",
    b"AFRT:540;0",
    b"SCAN:2400;U",
]
REAL_PP_REPLY = b"PP\n00P\n" + b"\n".join(REAL_PP_LINES) + b"\n\n"


def test_spec_examples_decode() -> None:
    assert scip.decode_value(b"1Dh") == 5432
    assert scip.decode_value(b"m2@0") == 16_000_000
    assert scip_encoder.encode_value(5432, 3) == b"1Dh"
    assert scip_encoder.encode_value(16_000_000, 4) == b"m2@0"


def test_two_char_encoding_and_range() -> None:
    assert scip.decode_value(b"0?") == 15
    assert scip_encoder.encode_value(4095, 2) == b"oo"
    with pytest.raises(ValueError):
        scip_encoder.encode_value(4096, 2)
    with pytest.raises(scip.ScipError):
        scip.decode_value(b"1D\x7f")


@settings(max_examples=150)
@given(st.lists(st.integers(0, (1 << 18) - 1), min_size=1, max_size=300), st.sampled_from([3]))
def test_array_round_trip_3char(values: list[int], chars: int) -> None:
    encoded = scip_encoder.encode_array(values, chars)
    assert len(encoded) == chars * len(values)
    assert scip.decode_array(encoded, chars).tolist() == values
    # The vectorised decoder agrees with the scalar one.
    assert [scip.decode_value(encoded[i : i + 3]) for i in range(0, len(encoded), 3)] == values


@settings(max_examples=100)
@given(st.lists(st.integers(0, (1 << 12) - 1), min_size=1, max_size=100))
def test_array_round_trip_2char(values: list[int]) -> None:
    assert scip.decode_array(scip_encoder.encode_array(values, 2), 2).tolist() == values


def test_status_sums() -> None:
    assert scip_encoder.status_line("00") == b"00P"
    assert scip_encoder.status_line("99") == b"99b"
    assert scip_encoder.status_line("0E") == b"0Ee"
    assert scip.parse_status(b"00P") == "00"
    assert scip.parse_status(b"0") == "0"  # SCIP 1.1 answer to SCIP2.0 carries no sum
    with pytest.raises(scip.ScipChecksumError):
        scip.parse_status(b"00Q")


def test_real_pp_reply_sums_exclude_semicolon() -> None:
    for line in REAL_PP_LINES:
        key, value = scip.parse_info_line(line)
        assert scip_encoder.info_line(key, value) == line
        # Including the ';' would give a different sum for these lines.
        assert scip.checksum(line[:-1]) != line[-1]
    info = scip.parse_info(scip.parse_reply(REAL_PP_REPLY), "PP")
    assert info["MODL"] == "UTM-30LX-EW"
    params = scip.SensorParameters.from_info(info)
    assert params.steps == 1081
    assert params.angle(540) == 0.0
    for step in (0, 180, 1080):
        assert params.angle(step) == pytest.approx((step - 540) * 2 * math.pi / 1440)
    assert params.scan_period == pytest.approx(0.025)
    assert (params.dmin, params.dmax) == (23, 60000)


def test_corrupted_info_line_is_rejected() -> None:
    with pytest.raises(scip.ScipChecksumError):
        scip.parse_info_line(b"AMAX:1081;Z")
    with pytest.raises(scip.ScipTruncatedError):
        scip.parse_info_line(b"AMAX:1080Z")
    reply = scip.parse_reply(b"PP\n0Ee\n\n")
    with pytest.raises(scip.ScipStatusError):
        scip.parse_info(reply, "PP")


def test_pp_missing_key_names_it() -> None:
    with pytest.raises(scip.ScipError, match="AFRT"):
        scip.SensorParameters.from_info(
            {
                "DMIN": "23",
                "DMAX": "60000",
                "ARES": "1440",
                "AMIN": "0",
                "AMAX": "1080",
                "SCAN": "2400",
            }
        )


def _md_frame(ranges: np.ndarray, timestamp: int = 1234) -> list[bytes]:
    echo = scip.md_command(0, ranges.size - 1)[:-1]
    return scip.split_frame(scip_encoder.encode_scan_frame(echo, "99", timestamp, ranges))


def test_full_gd_reply_is_3369_bytes() -> None:
    ranges = np.arange(1081) + 100
    frame = scip_encoder.encode_scan_frame(b"GD0000108000", "00", 0, ranges)
    assert len(frame) == 3369
    lines = scip.split_frame(frame)
    assert all(len(line) == 65 for line in lines[3:-1])
    with pytest.raises(scip.ScipError, match="not an MD/MS request"):  # the driver streams (MD)
        scip.parse_scan_frame(lines, 1081)
    decoded = scip.parse_scan_frame(_md_frame(ranges), 1081)  # the same data lines, streamed
    assert decoded.ranges_mm.tolist() == ranges.tolist()


def test_md_frame_round_trip() -> None:
    ranges = np.random.default_rng(3).integers(0, 60000, 1081)
    decoded = scip.parse_scan_frame(_md_frame(ranges, 16_000_000), 1081)
    assert decoded.timestamp_ms == 16_000_000
    assert np.array_equal(decoded.ranges_mm, ranges)
    assert decoded.remaining == 0


def test_md_frame_bad_sum_and_truncation_are_distinguished() -> None:
    ranges = np.full(1081, 5432)
    lines = _md_frame(ranges)
    bad = list(lines)
    bad[5] = bad[5][:3] + b"0" + bad[5][4:]
    with pytest.raises(scip.ScipChecksumError):
        scip.parse_scan_frame(bad, 1081)
    short = list(lines)
    short[6] = short[6][:30] + short[6][-1:]
    with pytest.raises(scip.ScipTruncatedError):
        scip.parse_scan_frame(short, 1081)
    with pytest.raises(scip.ScipTruncatedError):
        scip.parse_scan_frame(lines[:-1], 1081)  # a whole data line lost
    with pytest.raises(scip.ScipStatusError):
        scip.parse_scan_frame([lines[0], b"0Ee", *lines[2:]], 1081)


def test_md_command_format() -> None:
    assert scip.md_command(0, 1080) == b"MD0000108000000\n"
    req = scip.parse_md_request(b"MD0044072501000")
    assert (req.start, req.end, req.cluster, req.scans) == (44, 725, 1, 0)


def test_scan_clock_unwraps_and_stamps_first_beam() -> None:
    period = 0.025
    duration = 1080 / 1440 * period
    clock = scip.ScanClock(scan_duration=duration)
    offset = 100.0  # host time of sensor time 0 [s]
    start_ms = scip.TIMESTAMP_MODULUS - 60  # wraps after a few scans
    rng = np.random.default_rng(1)
    stamps = []
    for k in range(40):
        sensor_ms = start_ms + 25 * k
        rear = offset + sensor_ms / 1000.0
        first_beam = rear + 180 / 1440 * period
        received = rear + 1260 / 1440 * period + 0.001 + rng.uniform(0, 0.004)  # USB latency
        stamp = clock.stamp(sensor_ms % scip.TIMESTAMP_MODULUS, received)
        stamps.append(stamp)
        assert stamp <= received - duration + 1e-9
        if k > 10:
            assert stamp == pytest.approx(first_beam, abs=0.0025)
    assert np.all(np.diff(stamps) > 0.02)  # monotonic through the wrap
