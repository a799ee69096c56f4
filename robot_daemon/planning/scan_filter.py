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
The angles come from numpy, the pairs are judged in a compiled loop (`mark_veils`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from interbot_core.laser_scan import LaserScan
from robot_daemon import jit

SHADOW_MIN_ANGLE = math.radians(10.0)  # [rad] laser_filters' default min_angle
SHADOW_WINDOW = 1  # neighbours on each side


def shadow_mask(
    ranges: np.ndarray,
    angle_increment: float,
    min_angle: float = SHADOW_MIN_ANGLE,
    window: int = SHADOW_WINDOW,
) -> np.ndarray:
    """True for the veiling points of ``ranges`` (finite ranges only; see the module docstring).

    The angles ``alpha`` of every pair come from numpy's ``arctan2`` (whose last bits a
    compiled ``atan2`` need not share); which points they veil, from `mark_veils`.
    """
    r = np.ascontiguousarray(ranges, dtype=np.float64)
    bad = np.zeros(r.shape, dtype=bool)
    for k in range(1, window + 1):
        d_phi = k * angle_increment
        near, far = r[:-k], r[k:]
        with np.errstate(invalid="ignore"):
            # alpha at point i with neighbour i + k, and at point i + k with neighbour i
            forward = np.arctan2(far * math.sin(d_phi), near - far * math.cos(d_phi))
            backward = np.arctan2(near * math.sin(d_phi), far - near * math.cos(d_phi))
        mark_veils(r, k, forward, backward, float(min_angle), bad)
    return bad


@jit.kernel
def mark_veils(
    r: npt.NDArray[np.float64],
    k: int,
    forward: npt.NDArray[np.float64],
    backward: npt.NDArray[np.float64],
    min_angle: float,
    bad: npt.NDArray[np.bool_],
) -> None:
    """Set ``bad`` at the farther point of each shadow pair (i, i + k): both ranges finite and
    positive, and the angle at either point (``forward[i]`` at i, ``backward[i]`` at i + k)
    below ``min_angle`` or above ``pi - min_angle``. A pair of equal ranges veils neither."""
    lo, hi = min_angle, math.pi - min_angle
    for i in range(r.size - k):
        ri, rj = r[i], r[i + k]
        if not (math.isfinite(ri) and ri > 0 and math.isfinite(rj) and rj > 0):
            continue
        if forward[i] < lo or forward[i] > hi or backward[i] < lo or backward[i] > hi:
            if ri > rj:
                bad[i] = True
            elif rj > ri:
                bad[i + k] = True


def remove_shadows(scan: LaserScan, min_angle: float = SHADOW_MIN_ANGLE) -> LaserScan:
    """``scan`` with its veiling points turned into no-returns (+inf)."""
    mask = shadow_mask(scan.ranges, scan.angle_increment, min_angle)
    if not mask.any():
        return scan
    ranges = scan.ranges.copy()
    ranges[mask] = np.inf
    return dataclasses.replace(scan, ranges=ranges)


@jit.on_warm_up("planning.scan_filter")
def _warm_up() -> None:
    shadow_mask(np.array([1.0, 1.0, 3.0, 3.0, np.inf]), 0.01)
