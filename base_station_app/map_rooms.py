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

import yaml

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


def map_labels(topo: TopologicalMap, areas: Sequence[RoomArea], wrap: int = 16) -> list[MapLabel]:
    """One label per room, centred in its floor polygon and naming its own node ("Bar (13)"),
    so labels sit inside rooms instead of piling up on the corridor's door nodes; a node with
    no room polygon (and not a waypoint) is labelled at the node. Names longer than ``wrap``
    characters are broken onto several lines."""
    by_room: dict[str, list[RoomArea]] = {}
    for area in areas:
        if area.kind != "waypoint" and area.polygon:
            by_room.setdefault(area.room, []).append(area)
    labels: list[MapLabel] = []
    for room, members in by_room.items():
        members.sort(key=lambda a: (_KIND_ORDER.get(a.kind, 2), a.node_id))
        own = members[0]
        x, y = polygon_centroid(own.polygon)
        labels.append(MapLabel(_wrapped(f"{room} ({own.node_id})", wrap), x, y, own.node_id))
    placed = {m.node_id for members in by_room.values() for m in members}
    kinds = {a.node_id: a.kind for a in areas}
    for node in topo.nodes:
        if node.id in placed or kinds.get(node.id) == "waypoint":
            continue
        text = _wrapped(f"{node.name} ({node.id})", wrap)
        labels.append(MapLabel(text, node.pose.x, node.pose.y, node.id))
    return labels


def _wrapped(text: str, width: int) -> str:
    return "\n".join(textwrap.wrap(text, width))
