"""The navigator's path as the station draws it: thinned to a spacing, ends kept.

A grid path has a point every cell (5 cm); the station needs the shape, not every cell. Points
closer than ``spacing`` to the last kept one are dropped (the last point is always kept), and
if the result is still longer than ``max_points`` the spacing grows until it fits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from interbot_core.topics import MAX_LIST_LENGTH, PlanMsg


def thin_path(
    points: Sequence[tuple[float, float]], spacing: float = 0.2, max_points: int = MAX_LIST_LENGTH
) -> tuple[tuple[float, float], ...]:
    """Every point at least ``spacing`` [m] from the previous kept one, plus the last point."""
    if spacing <= 0.0 or max_points < 2:
        raise ValueError(f"spacing must be > 0 and max_points >= 2, got {spacing}, {max_points}")
    while True:
        kept: list[tuple[float, float]] = []
        for p in points:
            if not kept or math.dist(p, kept[-1]) >= spacing:
                kept.append((float(p[0]), float(p[1])))
        if points and kept[-1] != tuple(points[-1]):
            kept.append((float(points[-1][0]), float(points[-1][1])))
        if len(kept) <= max_points:
            return tuple(kept)
        spacing *= 2.0


def plan_message(
    route_id: int, path: Sequence[tuple[float, float]], stamp: float, spacing: float = 0.2
) -> PlanMsg:
    return PlanMsg(route_id, thin_path(path, spacing), stamp)
