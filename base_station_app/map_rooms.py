"""Rooms on the station's map: which node a click on the floor plan means (thesis §5.3 "Tasks").

The topological map YAML may give each node extra keys that the core loader ignores: ``room``
(the room it belongs to), ``kind`` (``entrance``, ``inside`` or ``waypoint``) and ``area`` (the
room's floor polygon, ``[[x, y], ...]`` in the ``map`` frame). `load_room_areas` reads them and
`room_at` picks the node a click at ``(x, y)`` selects: a node whose area contains the point
(``inside`` nodes before ``entrance`` nodes, as the room's own node), else the nearest room node
(not a waypoint) within ``snap_radius`` metres, else None. Point in polygon is the even-odd
ray-crossing rule.
"""

from __future__ import annotations

import logging
import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from scipy import ndimage

from interbot_core.occupancy_grid import FREE, OccupancyGrid
from interbot_core.topological_map import TopologicalMap

logger = logging.getLogger(__name__)

_KIND_ORDER = {"inside": 0, "entrance": 1}


@dataclass(frozen=True)
class RoomArea:
    node_id: int
    room: str
    kind: str  # entrance, inside, waypoint
    polygon: tuple[tuple[float, float], ...]  # [m] map frame; empty when none


def point_in_polygon(x: float, y: float, polygon: Sequence[tuple[float, float]]) -> bool:
    """Even-odd rule: count crossings of a ray from (x, y) towards +x."""
    inside = False
    n = len(polygon)
    for i in range(n):
        x1, y1 = polygon[i]
        x2, y2 = polygon[(i + 1) % n]
        if (y1 > y) != (y2 > y):
            x_cross = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
            if x < x_cross:
                inside = not inside
    return inside


def load_room_areas(path: str | Path, topo: TopologicalMap) -> list[RoomArea]:
    """Room data of every node of ``topo`` from its YAML file (defaults when keys are absent)."""
    try:
        raw = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
        nodes = {int(n["id"]): n for n in raw.get("nodes", []) if isinstance(n, dict)}
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
        logger.warning("%s: no room areas (%s); clicks snap to nodes only", path, exc)
        nodes = {}
    areas: list[RoomArea] = []
    for node in topo.nodes:
        entry = nodes.get(node.id, {})
        polygon: tuple[tuple[float, float], ...] = ()
        try:
            polygon = tuple((float(p[0]), float(p[1])) for p in entry.get("area") or ())
        except (TypeError, ValueError, IndexError):
            logger.warning("%s: node %d has a malformed area; ignored", path, node.id)
        kind = str(entry.get("kind") or "entrance")
        room = str(entry.get("room") or node.name)
        areas.append(RoomArea(node.id, room, kind, polygon if len(polygon) >= 3 else ()))
    return areas


def room_at(
    x: float, y: float, topo: TopologicalMap, areas: Sequence[RoomArea], snap_radius: float = 1.5
) -> int | None:
    """The node a click at (x, y) [m] selects, or None (see the module docstring)."""
    hits = [a for a in areas if a.polygon and point_in_polygon(x, y, a.polygon)]
    if hits:
        hits.sort(key=lambda a: (_KIND_ORDER.get(a.kind, 2), a.node_id))
        return hits[0].node_id
    kinds = {a.node_id: a.kind for a in areas}
    best, best_d = None, snap_radius
    for node in topo.nodes:
        if kinds.get(node.id) == "waypoint":
            continue
        d = math.hypot(node.pose.x - x, node.pose.y - y)
        if d <= best_d:
            best, best_d = node.id, d
    return best


@dataclass(frozen=True)
class MapLabel:
    """A label on the station's map: ``text`` centred at (x, y) [m], map frame."""

    text: str
    x: float
    y: float
    node_id: int  # the node a click on this room selects (its own node)
    short: str = ""  # shown when the room is too small on screen for ``text`` (its number)
    width: float = math.inf  # [m] room width available to the label


def clearest_point(
    polygon: Sequence[tuple[float, float]], grid: OccupancyGrid
) -> tuple[float, float] | None:
    """The free cell inside ``polygon`` farthest from anything that is not free (furniture,
    walls, unknown), ties broken towards the centroid; None if no free cell is inside.

    A pole of inaccessibility on the map's free space: ``scipy.ndimage.distance_transform_edt``
    of the free mask over the polygon's bounding box, masked to the polygon (even-odd rule).
    """
    xs = np.array([p[0] for p in polygon])
    ys = np.array([p[1] for p in polygon])
    (r0, r1), (c0, c1) = _rows_cols(grid, xs, ys)
    if r1 < r0 or c1 < c0:
        return None
    rows, cols = np.mgrid[r0 : r1 + 1, c0 : c1 + 1]
    wx, wy = grid.cell_to_world(rows, cols)
    inside = _inside(wx, wy, xs, ys)
    free = grid.cells[r0 : r1 + 1, c0 : c1 + 1] == FREE
    clearance = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1]
    clearance = np.where(inside & free, clearance * grid.resolution, -1.0)
    if clearance.max() <= 0:
        return None
    cx, cy = polygon_centroid(polygon)
    score = clearance - 0.05 * np.hypot(wx - cx, wy - cy)
    i = np.unravel_index(int(np.argmax(score)), score.shape)
    return float(wx[i]), float(wy[i])


def _rows_cols(
    grid: OccupancyGrid, xs: np.ndarray, ys: np.ndarray
) -> tuple[tuple[int, int], tuple[int, int]]:
    c0 = max(0, int((xs.min() - grid.origin_x) / grid.resolution))
    c1 = min(grid.width - 1, int((xs.max() - grid.origin_x) / grid.resolution))
    r0 = max(0, int((ys.min() - grid.origin_y) / grid.resolution))
    r1 = min(grid.height - 1, int((ys.max() - grid.origin_y) / grid.resolution))
    return (r0, r1), (c0, c1)


def _inside(px: np.ndarray, py: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """`point_in_polygon` for arrays of points (even-odd rule, vectorised over the points)."""
    inside = np.zeros(px.shape, dtype=bool)
    n = len(xs)
    for i in range(n):
        x1, y1, x2, y2 = xs[i], ys[i], xs[(i + 1) % n], ys[(i + 1) % n]
        if y1 == y2:
            continue
        crosses = ((y1 > py) != (y2 > py)) & (px < x1 + (py - y1) * (x2 - x1) / (y2 - y1))
        inside ^= crosses
    return inside


def polygon_centroid(polygon: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """Area centroid of a simple polygon (shoelace); the vertex mean if it is degenerate."""
    a = cx = cy = 0.0
    n = len(polygon)
    for i in range(n):
        x1, y1 = polygon[i]
        x2, y2 = polygon[(i + 1) % n]
        cross = x1 * y2 - x2 * y1
        a += cross
        cx += (x1 + x2) * cross
        cy += (y1 + y2) * cross
    if abs(a) < 1e-12:
        return sum(p[0] for p in polygon) / n, sum(p[1] for p in polygon) / n
    return cx / (3.0 * a), cy / (3.0 * a)


def map_labels(
    topo: TopologicalMap,
    areas: Sequence[RoomArea],
    wrap: int = 16,
    grid: OccupancyGrid | None = None,
) -> list[MapLabel]:
    """One label per room, inside its floor polygon and naming its own node ("Bar (13)"), so
    labels sit inside rooms instead of piling up on the corridor's door nodes; a node with no
    room polygon (and not a waypoint) is labelled at the node. Names longer than ``wrap``
    characters are broken onto several lines. With the map's ``grid`` a label goes to the
    clearest floor of its room (`clearest_point`), not on furniture; else the centroid."""
    by_room: dict[str, list[RoomArea]] = {}
    for area in areas:
        if area.kind != "waypoint" and area.polygon:
            by_room.setdefault(area.room, []).append(area)
    labels: list[MapLabel] = []
    for room, members in by_room.items():
        members.sort(key=lambda a: (_KIND_ORDER.get(a.kind, 2), a.node_id))
        own = members[0]
        spot = clearest_point(own.polygon, grid) if grid is not None else None
        x, y = spot if spot is not None else polygon_centroid(own.polygon)
        width = max(p[0] for p in own.polygon) - min(p[0] for p in own.polygon)
        text = _wrapped(f"{room} ({own.node_id})", wrap)
        labels.append(MapLabel(text, x, y, own.node_id, str(own.node_id), width))
    placed = {m.node_id for members in by_room.values() for m in members}
    kinds = {a.node_id: a.kind for a in areas}
    for node in topo.nodes:
        if node.id in placed or kinds.get(node.id) == "waypoint":
            continue
        text = _wrapped(f"{node.name} ({node.id})", wrap)
        labels.append(MapLabel(text, node.pose.x, node.pose.y, node.id, str(node.id)))
    return labels


def _wrapped(text: str, width: int) -> str:
    return "\n".join(textwrap.wrap(text, width))
