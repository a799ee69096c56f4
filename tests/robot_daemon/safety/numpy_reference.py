"""The numpy code the safety kernels replaced (session 13), kept as the tests' reference: each
kernel must give what this code gave, bit for bit (`test_safety_kernels`)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon.safety.arc_geometry import (
    FloatArray,
    distance_to_polygon,
    inside_polygon,
    polygon_radius,
)
from robot_daemon.safety.collision_monitor import CollisionMonitor


def numpy_first_contact(
    px: FloatArray,
    py: FloatArray,
    x: FloatArray,
    y: FloatArray,
    cos_t: FloatArray,
    sin_t: FloatArray,
    poly: FloatArray,
    min_points: int = 1,
) -> npt.NDArray[np.intp]:
    """Index of the first pose (per row of the (C, K) pose arrays) at which at least
    ``min_points`` of the (N,) points lie inside ``poly``; K where none does."""
    dx = px[None, None, :] - x[..., None]
    dy = py[None, None, :] - y[..., None]
    c, s = cos_t[..., None], sin_t[..., None]
    lx = c * dx + s * dy
    ly = c * dy - s * dx
    hits = np.count_nonzero(inside_polygon(lx, ly, poly), axis=-1) >= min_points  # (C, K)
    k = hits.shape[-1]
    first: npt.NDArray[np.intp] = np.where(hits.any(axis=-1), hits.argmax(axis=-1), k)
    return first


def numpy_near_arcs(
    px: FloatArray, py: FloatArray, curvatures: FloatArray, radius: float, length: float
) -> npt.NDArray[np.bool_]:
    """Points that a footprint of circumscribed ``radius`` [m] could touch while base_link moves
    up to ``|length|`` along any of the arcs: within ``radius`` of the arc's circle (of the
    x axis for a straight line) and of the origin plus ``|length|``. A cheap superset that keeps
    the per-step tests small (walls beside a straight run drop out)."""
    keep = np.zeros(np.shape(px), dtype=bool)
    for kappa in np.asarray(curvatures, dtype=np.float64).ravel():
        if abs(kappa) < 1e-6:
            keep |= np.abs(py) <= radius
        else:
            rho = 1.0 / kappa
            keep |= np.abs(np.hypot(px, py - rho) - abs(rho)) <= radius
    within: npt.NDArray[np.bool_] = keep & (np.hypot(px, py) <= radius + abs(length))
    return within


class NumpyCollisionMonitor(CollisionMonitor):
    """`CollisionMonitor` evaluating its zones with numpy (session 12)."""

    def _update_zones(self) -> None:
        px, py = self._px, self._py
        near = np.hypot(px, py)
        h = self.config.hysteresis
        fp_reach = polygon_radius(self._footprint)
        close = near <= fp_reach + 1.0
        self._distance = (
            float(distance_to_polygon(px[close], py[close], self._footprint).min())
            if np.any(close)
            else math.inf
        )
        for zone in self._zones:
            if zone.config.action_type == "approach":
                continue
            cand = near <= zone.reach + h
            zx, zy = px[cand], py[cand]
            inside = inside_polygon(zx, zy, zone.polygon)
            if zone.active and h > 0:
                member = inside | (distance_to_polygon(zx, zy, zone.polygon) <= h)
            else:
                member = inside
            zone.active = int(np.count_nonzero(member)) >= zone.config.min_points
            zone.members = (
                np.column_stack((zx[member], zy[member])) if zone.active else np.zeros((0, 2))
            )
