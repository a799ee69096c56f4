"""Veiling ("shadow", mixed-pixel) points removed from a laser scan before it marks obstacles.

A beam whose spot straddles an edge returns a range between the foreground and the background
(a mixed pixel, Tang et al., "Characterization of the Hokuyo URG-04LX", 2009): a phantom point
floating in a doorway or beside a person, where nothing is. Marked into the costmap and inflated,
a few of them close a 0.9 m door. ROS ``laser_filters``' ScanShadowsFilter removes them by
geometry: for a point P_i and a neighbour P_j (``j = i +- 1 .. window``) the angle at P_i in the
triangle (sensor, P_i, P_j),

    alpha = atan2(r_j sin(d_phi), r_i - r_j cos(d_phi)),   d_phi = (j - i) * angle_increment,

is near 0 or 180 degrees only when P_j lies almost along the beam through P_i: a surface seen
edge-on, which is what a veiling point looks like. Points with ``alpha < min_angle`` or
``alpha > 180 deg - min_angle`` for a neighbour form a shadow pair, and the farther point of the
pair is dropped (set to +inf, REP-117 "no return"); the nearer one is the obstacle's real edge.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from interbot_core.laser_scan import LaserScan

SHADOW_MIN_ANGLE = math.radians(10.0)  # [rad] laser_filters' default min_angle
SHADOW_WINDOW = 1  # neighbours on each side


def shadow_mask(
    ranges: np.ndarray,
    angle_increment: float,
    min_angle: float = SHADOW_MIN_ANGLE,
    window: int = SHADOW_WINDOW,
) -> np.ndarray:
    """True for the veiling points of ``ranges`` (finite ranges only; see the module docstring)."""
    r = np.asarray(ranges, dtype=np.float64)
    finite = np.isfinite(r) & (r > 0)
    bad = np.zeros(r.shape, dtype=bool)
    lo, hi = min_angle, math.pi - min_angle
    for k in range(1, window + 1):
        d_phi = k * angle_increment
        for a, b in ((slice(None, -k), slice(k, None)), (slice(k, None), slice(None, -k))):
            ri, rj = r[a], r[b]
            both = finite[a] & finite[b]
            with np.errstate(invalid="ignore"):
                alpha = np.arctan2(rj * math.sin(d_phi), ri - rj * math.cos(d_phi))
            shadow = both & ((alpha < lo) | (alpha > hi))
            # As laser_filters does: of a shadow pair, drop the farther point (the veil), keep
            # the nearer one (the obstacle's true edge).
            bad[a] |= shadow & (ri > rj)
            bad[b] |= shadow & (rj > ri)
    return bad


def remove_shadows(scan: LaserScan, min_angle: float = SHADOW_MIN_ANGLE) -> LaserScan:
    """``scan`` with its veiling points turned into no-returns (+inf)."""
    mask = shadow_mask(scan.ranges, scan.angle_increment, min_angle)
    if not mask.any():
        return scan
    ranges = scan.ranges.copy()
    ranges[mask] = np.inf
    return dataclasses.replace(scan, ranges=ranges)
