from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.laser_scan import (
    UTM30LX_ANGLE_INCREMENT,
    UTM30LX_ANGLE_MIN,
    UTM30LX_BEAMS,
    LaserScan,
)


def test_utm30lx_geometry_covers_270_degrees() -> None:
    last = UTM30LX_ANGLE_MIN + UTM30LX_ANGLE_INCREMENT * (UTM30LX_BEAMS - 1)
    assert math.degrees(last) == pytest.approx(135.0)


def test_points_skip_invalid_returns() -> None:
    scan = LaserScan(0.0, -math.pi / 2, math.pi / 2, 0.1, 30.0, np.array([1.0, np.inf, 2.0, 0.05]))
    pts = scan.points()
    assert pts.shape == (2, 2)
    np.testing.assert_allclose(pts[0], [0.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(pts[1], [0.0, 2.0], atol=1e-6)
    assert scan.valid().tolist() == [True, False, True, False]


def test_scan_is_immutable_and_validated() -> None:
    scan = LaserScan(0.0, 0.0, 0.1, 0.1, 30.0, np.ones(3))
    with pytest.raises(ValueError):
        scan.ranges[0] = 5.0
    with pytest.raises(ValueError, match="range_min"):
        LaserScan(0.0, 0.0, 0.1, 5.0, 1.0, np.ones(3))


def test_points_from_the_shared_trig_equal_the_cosines_of_the_valid_beams() -> None:
    """`LaserScan.points` (and the costmap's marks) take the cosines of every beam once per
    beam geometry and pick the valid ones: the same numbers as the cosines of the valid
    beams' angles, bit for bit (numpy's cos is elementwise)."""
    rng = np.random.default_rng(3)
    for k in range(200):
        n = int(rng.integers(10, 1500))
        ranges = rng.uniform(0.0, 35.0, n).astype(np.float32)
        ranges[rng.random(n) < 0.1] = np.inf
        scan = LaserScan(
            0.1 * k,
            float(rng.uniform(-3.0, 0.0)),
            float(rng.uniform(1e-3, 0.01)),
            0.1,
            30.0,
            ranges,
        )
        for max_range in (None, float(rng.uniform(1.0, 20.0))):
            mask = scan.valid()
            if max_range is not None:
                mask &= scan.ranges <= max_range
            a = scan.angle_min + scan.angle_increment * np.arange(n, dtype=np.float64)
            r = scan.ranges[mask].astype(np.float64)
            plain = np.column_stack((r * np.cos(a[mask]), r * np.sin(a[mask])))
            assert np.array_equal(scan.points(max_range), plain)
        assert np.array_equal(scan.angles, a)


def test_shared_beam_trig_is_read_only_and_angles_are_a_fresh_copy() -> None:
    scan = LaserScan(0.0, -1.0, 0.01, 0.1, 30.0, np.ones(50, dtype=np.float32))
    cos, sin = scan.trig()
    with pytest.raises(ValueError):
        cos[0] = 2.0
    angles = scan.angles
    angles[0] = 5.0  # the caller's own array
    assert scan.angles[0] == -1.0
    assert np.array_equal(cos, np.cos(scan.angles)) and np.array_equal(sin, np.sin(scan.angles))
