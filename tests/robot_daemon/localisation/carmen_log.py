"""Reader for CARMEN text logs (the Radish / Freiburg SLAM data sets), plain or gzip.

Format (CARMEN robot logger, "old" laser messages)::

    FLASER n r1 .. rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    ODOM x y theta tv rv accel timestamp host logger_timestamp

``x y theta`` on a FLASER line is the pose of the laser (robot pose plus the front-laser offset,
zero in the stored logs); ``odom_*`` the robot's odometry. In the "corrected" logs both hold the
same SLAM-corrected pose. Lines of other types (``PARAM``, ``SYNC``, ``NEFF``, ``RLASER``,
``ROBOTLASER1`` ...), comments (``#``) and blank lines are skipped.

Beam geometry. The old FLASER message carries no angles; the field of view is 180 degrees and
beam 0 points to the right (-90 degrees). We use ``angle_min = -pi/2`` and an increment of ``pi/180`` for 180 or 181 beams, ``pi/360`` for 360 or 361 beams (in general
``pi / (n - 1)`` when ``n`` is odd and ``pi / n`` when ``n`` is even). So a 181/361-beam scan
spans -90..+90 degrees inclusive, while a 180/360-beam scan spans -90..+89 (+89.5) degrees. (We believe GMapping's CARMEN reader, which produced the
corrected poses, does the same, but have not checked its source.) We checked this on the data with a cross-consistency measure (fraction of the end points of every
other scan within 5 cm of the map built from the remaining scans with their logged poses; see
tests/robot_daemon/localisation/test_loc_realdata.py): Intel (180 beams) 0.956 with ``pi/n`` from
-90 degrees, 0.943 with ``pi/(n-1)``, 0.947 / 0.948 with the start shifted by +-half a step;
Freiburg 079 (360 beams) cannot tell them apart (0.947..0.949).

Readings at or above ``no_return_range`` (default 80 m; the SICK LMS logs use 81.83 m or 81.91 m
for "no return") are left in ``ranges`` but lie above the scan's ``range_max``, so
`LaserScan.valid` rejects them.
"""

from __future__ import annotations

import gzip
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan

DEFAULT_NO_RETURN_RANGE = 80.0  # [m] readings >= this are "no return"
DEFAULT_RANGE_MIN = 0.01  # [m] shorter readings are sensor errors


class CarmenLogError(ValueError):
    """A CARMEN log line is malformed; the message names the file and line number."""


@dataclass(frozen=True)
class LaserRecord:
    """One FLASER line: the scan, the logged laser pose and odometry pose, and the time [s]."""

    scan: LaserScan
    pose: Pose2D  # logged laser pose (corrected logs: SLAM-corrected robot pose)
    odom_pose: Pose2D
    timestamp: float  # [s]
    line_number: int


@dataclass(frozen=True)
class OdomRecord:
    """One ODOM line: pose, velocities and time."""

    pose: Pose2D
    tv: float  # [m/s]
    rv: float  # [rad/s]
    accel: float  # [m/s^2]
    timestamp: float  # [s]
    line_number: int


CarmenRecord = LaserRecord | OdomRecord


def flaser_angle_increment(n_beams: int) -> float:
    """Angular step [rad] of a 180-degree FLASER scan with ``n_beams`` readings.

    ``pi / (n - 1)`` for an odd count (181, 361: both ends included), ``pi / n`` for an even one
    (180, 360), as CARMEN and GMapping read these logs.
    """
    if n_beams < 2:
        raise ValueError(f"a FLASER scan needs at least 2 beams, got {n_beams}")
    return math.pi / (n_beams - 1) if n_beams % 2 == 1 else math.pi / n_beams


def _floats(tokens: list[str], where: str, what: str) -> list[float]:
    try:
        values = [float(t) for t in tokens]
    except ValueError as exc:
        raise CarmenLogError(f"{where}: {what} must be numbers ({exc})") from exc
    if not all(math.isfinite(v) for v in values):
        raise CarmenLogError(f"{where}: {what} must be finite numbers")
    return values


def _parse_flaser(
    tokens: list[str], where: str, line_number: int, no_return_range: float
) -> LaserRecord:
    if len(tokens) < 2:
        raise CarmenLogError(f"{where}: FLASER line has no beam count")
    try:
        n = int(tokens[1])
    except ValueError as exc:
        raise CarmenLogError(f"{where}: FLASER beam count {tokens[1]!r} is not an integer") from exc
    if not 2 <= n <= 100_000:
        raise CarmenLogError(f"{where}: FLASER beam count must be 2..100000, got {n}")
    # n ranges, 6 pose values, timestamp, host, logger timestamp (the last may be missing).
    need = 2 + n + 7
    if len(tokens) < need + 1:
        raise CarmenLogError(
            f"{where}: FLASER with {n} beams needs at least {need + 1} fields "
            f"(ranges, x y theta odom_x odom_y odom_theta timestamp host), got {len(tokens)}"
        )
    ranges = np.array(_floats(tokens[2 : 2 + n], where, "FLASER ranges"), dtype=np.float32)
    if np.any(ranges < 0):
        raise CarmenLogError(f"{where}: FLASER ranges must be >= 0")
    x, y, th, ox, oy, oth, stamp = _floats(tokens[2 + n : need], where, "FLASER pose/timestamp")
    # A reading equal to the no-return code is rejected too: range_max sits one float32 step
    # below it (ranges are float32, and numpy compares them in float32).
    range_max = float(np.nextafter(np.float32(no_return_range), np.float32(0.0)))
    scan = LaserScan(
        stamp=stamp,
        angle_min=-math.pi / 2,
        angle_increment=flaser_angle_increment(n),
        range_min=DEFAULT_RANGE_MIN,
        range_max=range_max,
        ranges=ranges,
    )
    return LaserRecord(scan, Pose2D(x, y, th), Pose2D(ox, oy, oth), stamp, line_number)


def _parse_odom(tokens: list[str], where: str, line_number: int) -> OdomRecord:
    if len(tokens) < 8:
        raise CarmenLogError(
            f"{where}: ODOM needs 'x y theta tv rv accel timestamp host', got {len(tokens) - 1}"
            " fields"
        )
    x, y, th, tv, rv, acc, stamp = _floats(tokens[1:8], where, "ODOM fields")
    return OdomRecord(Pose2D(x, y, th), tv, rv, acc, stamp, line_number)


def parse_line(
    line: str,
    line_number: int,
    source: str = "<log>",
    no_return_range: float = DEFAULT_NO_RETURN_RANGE,
) -> CarmenRecord | None:
    """Parse one log line; ``None`` for comments, blank lines and unknown record types."""
    tokens = line.split()
    if not tokens or tokens[0].startswith("#"):
        return None
    where = f"{source}:{line_number}"
    if tokens[0] == "FLASER":
        return _parse_flaser(tokens, where, line_number, no_return_range)
    if tokens[0] == "ODOM":
        return _parse_odom(tokens, where, line_number)
    return None


def iter_carmen_log(
    path: str | Path, no_return_range: float = DEFAULT_NO_RETURN_RANGE
) -> Iterator[CarmenRecord]:
    """Yield the FLASER and ODOM records of a CARMEN log (``.gz`` is decompressed)."""
    if not (math.isfinite(no_return_range) and no_return_range > DEFAULT_RANGE_MIN):
        raise ValueError(f"no_return_range must be > {DEFAULT_RANGE_MIN} m, got {no_return_range}")
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", encoding="ascii", errors="replace") as fh:
            for number, line in enumerate(fh, start=1):
                record = parse_line(line, number, str(path), no_return_range)
                if record is not None:
                    yield record
    except OSError as exc:
        raise CarmenLogError(f"{path}: cannot read CARMEN log ({exc})") from exc


def read_laser_records(
    path: str | Path, no_return_range: float = DEFAULT_NO_RETURN_RANGE
) -> list[LaserRecord]:
    """All FLASER records of a log, in file order."""
    return [r for r in iter_carmen_log(path, no_return_range) if isinstance(r, LaserRecord)]
