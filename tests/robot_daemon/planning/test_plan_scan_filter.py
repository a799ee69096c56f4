"""Veiling points (mixed pixels) are removed before they mark obstacles; real edges stay."""

from __future__ import annotations

import math

import numpy as np

from interbot_core.laser_scan import LaserScan
from robot_daemon.planning.scan_filter import remove_shadows, shadow_mask

INC = math.radians(0.25)


def _scan(ranges: np.ndarray) -> LaserScan:
    return LaserScan(
        stamp=0.0,
        angle_min=-0.5 * INC * (ranges.size - 1),
        angle_increment=INC,
        range_min=0.1,
        range_max=30.0,
        ranges=ranges.astype(np.float32),
    )


def test_veil_between_a_person_and_the_wall_is_removed_edges_kept() -> None:
    ranges = np.full(41, 5.0)
    ranges[15:26] = 2.0  # a person at 2 m in front of a wall at 5 m
    ranges[14] = 3.4  # a mixed pixel at its left edge
    ranges[26] = 2.7  # and at its right edge
    mask = shadow_mask(ranges, INC)
    assert mask[14] and mask[26]
    assert not mask[15:26].any()  # the person's own edge points stay
    assert not mask[:13].any() and not mask[28:].any()  # the wall far from the edges stays
    out = remove_shadows(_scan(ranges))
    assert np.isinf(out.ranges[14]) and np.isinf(out.ranges[26])
    assert out.ranges[15] == np.float32(2.0)


def test_a_wall_seen_face_on_is_untouched() -> None:
    angles = INC * (np.arange(201) - 100)
    ranges = 3.0 / np.cos(angles)  # a wall 3 m ahead, +-25 degrees
    assert not shadow_mask(ranges, INC).any()
    scan = _scan(ranges)
    assert remove_shadows(scan) is scan


def test_no_returns_are_ignored() -> None:
    ranges = np.array([np.inf, 2.0, np.nan, 2.0, -np.inf, 2.0])
    assert not shadow_mask(ranges, INC).any()
