"""CARMEN log reader: FLASER / ODOM parsing, validation with line numbers, beam geometry."""

from __future__ import annotations

import gzip
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.robot_daemon.localisation.carmen_log import (
    CarmenLogError,
    LaserRecord,
    OdomRecord,
    flaser_angle_increment,
    iter_carmen_log,
    parse_line,
    read_laser_records,
)

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"


def _flaser(
    ranges: list[float], pose: tuple[float, float, float] = (1.0, 2.0, 0.5), stamp: float = 12.5
) -> str:
    r = " ".join(f"{v:g}" for v in ranges)
    x, y, th = pose
    return f"FLASER {len(ranges)} {r} {x} {y} {th} {x} {y} {th} {stamp} pippo {stamp}"


def test_parse_flaser_line() -> None:
    rec = parse_line(_flaser([1.0, 2.0, 81.83, 3.5]), 7)
    assert isinstance(rec, LaserRecord)
    assert rec.line_number == 7 and rec.timestamp == 12.5
    assert (rec.pose.x, rec.pose.y, rec.pose.yaw) == (1.0, 2.0, 0.5)
    assert rec.scan.angle_min == pytest.approx(-math.pi / 2)
    assert rec.scan.angle_increment == pytest.approx(math.pi / 4)
    # The no-return code (81.83 m) is not a valid return.
    assert rec.scan.valid().tolist() == [True, True, False, True]
    assert rec.scan.points().shape == (3, 2)
    # Beam 0 points to the right (-y), REP-103.
    assert rec.scan.points()[0] == pytest.approx([0.0, -1.0], abs=1e-12)


def test_no_return_at_exactly_the_code_value_is_invalid() -> None:
    rec = parse_line(_flaser([80.0, 5.0]), 1, no_return_range=80.0)
    assert isinstance(rec, LaserRecord)
    assert rec.scan.valid().tolist() == [False, True]


def test_parse_odom_line() -> None:
    rec = parse_line("ODOM 1.5 -2 0.1 0.3 0.05 0 33.2 pippo 33.2", 3)
    assert isinstance(rec, OdomRecord)
    assert (rec.pose.x, rec.pose.y, rec.tv, rec.rv, rec.timestamp) == (1.5, -2.0, 0.3, 0.05, 33.2)


@pytest.mark.parametrize(
    "line",
    [
        "",
        "   ",
        "# message formats defined: PARAM SYNC ODOM FLASER",
        "PARAM robot_x 1 h 0",
        "NEFF 15",
        "RLASER 2 1 1 0 0 0 0 0 0 0 h 0",
        "SYNC x",
    ],
)
def test_comments_and_unknown_records_are_skipped(line: str) -> None:
    assert parse_line(line, 1) is None


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("FLASER", "no beam count"),
        ("FLASER x 1 2", "not an integer"),
        ("FLASER 1 1.0 0 0 0 0 0 0 1 h 1", "2..100000"),
        ("FLASER 3 1 2 3 0 0 0 0 0 0", "at least 13 fields"),
        ("FLASER 2 1 abc 0 0 0 0 0 0 1 h 1", "ranges must be numbers"),
        ("FLASER 2 1 -2 0 0 0 0 0 0 1 h 1", ">= 0"),
        ("FLASER 2 1 2 0 nan 0 0 0 0 1 h 1", "finite"),
        ("ODOM 1 2 3", "ODOM needs"),
        ("ODOM 1 2 x 0 0 0 5 h 5", "ODOM fields must be numbers"),
    ],
)
def test_malformed_lines_name_file_and_line(line: str, message: str) -> None:
    with pytest.raises(CarmenLogError, match=message) as info:
        parse_line(line, 42, "robot.log")
    assert "robot.log:42" in str(info.value)


def test_reads_gzip_and_reports_the_line_number(tmp_path: Path) -> None:
    good = [
        _flaser([1.0, 2.0], stamp=1.0),
        "ODOM 0 0 0 0 0 0 1.1 h 1.1",
        _flaser([3.0, 4.0], stamp=2.0),
    ]
    path = tmp_path / "run.log.gz"
    with gzip.open(path, "wt", encoding="ascii") as fh:
        fh.write("# header\n" + "\n".join(good) + "\n")
    records = list(iter_carmen_log(path))
    assert [type(r) for r in records] == [LaserRecord, OdomRecord, LaserRecord]
    assert [r.line_number for r in records] == [2, 3, 4]
    assert [r.timestamp for r in read_laser_records(path)] == [1.0, 2.0]
    bad = tmp_path / "bad.log"
    bad.write_text("\n".join([*good, "FLASER 2 1.0"]) + "\n", encoding="ascii")
    with pytest.raises(CarmenLogError, match=r"bad\.log:4"):
        read_laser_records(bad)


def test_missing_file_is_a_carmen_log_error(tmp_path: Path) -> None:
    with pytest.raises(CarmenLogError, match="cannot read"):
        read_laser_records(tmp_path / "absent.log")


def test_angle_increment_convention() -> None:
    assert flaser_angle_increment(180) == pytest.approx(math.radians(1.0))
    assert flaser_angle_increment(181) == pytest.approx(math.radians(1.0))
    assert flaser_angle_increment(360) == pytest.approx(math.radians(0.5))
    assert flaser_angle_increment(361) == pytest.approx(math.radians(0.5))
    with pytest.raises(ValueError):
        flaser_angle_increment(1)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.floats(0.02, 79.0, allow_nan=False), min_size=2, max_size=400),
    st.floats(-100, 100),
    st.floats(-100, 100),
    st.floats(-3.1, 3.1),
    st.floats(0, 1e9),
)
def test_flaser_round_trip(
    ranges: list[float], x: float, y: float, th: float, stamp: float
) -> None:
    line = " ".join(
        [
            "FLASER",
            str(len(ranges)),
            *map(repr, ranges),
            *map(repr, (x, y, th, x, y, th, stamp)),
            "h",
            "0",
        ]
    )
    rec = parse_line(line, 1)
    assert isinstance(rec, LaserRecord)
    assert np.allclose(rec.scan.ranges, np.array(ranges, dtype=np.float32))
    assert rec.scan.valid().all()
    assert rec.pose.x == x and rec.pose.y == y and rec.timestamp == stamp
    # Last beam: +90 deg for odd counts, one step short of it for even counts.
    last = rec.scan.angle_min + (len(ranges) - 1) * rec.scan.angle_increment
    expected = math.pi / 2 if len(ranges) % 2 else math.pi / 2 - math.pi / len(ranges)
    assert last == pytest.approx(expected)


@pytest.mark.realdata
@pytest.mark.parametrize(
    ("name", "count", "beams"), [("intel", 910, 180), ("freiburg-079", 4791, 360)]
)
def test_real_logs_read(name: str, count: int, beams: int) -> None:
    path = LOGS / f"{name}-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)
    assert len(records) == count
    assert all(r.scan.ranges.size == beams for r in records)
    # The Intel log has 4 scans stamped up to 0.9 s before their predecessor; tolerate a few.
    backwards = sum(b.timestamp < a.timestamp for a, b in itertools.pairwise(records))
    assert backwards <= 5
    valid = np.mean([r.scan.valid().mean() for r in records])
    assert 0.5 < valid < 1.0  # some no-return readings are rejected
