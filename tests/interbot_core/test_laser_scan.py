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
