"""The rooms the Tablet shows on its map (thesis §5.2.1, Appendix I Figs. 1 and 3).

Each node of the topological map (`interbot_core.topological_map`) is a room the user can touch:
its name, the info text shown in the room dialog and at a guided-tour stop, whether requests
can be picked up there, and its ``area``: the room's outline ``[[x, y], ...]`` [m] in the
``map`` frame, the surface the thesis "directly linked to a button". The topological-map loader
ignores ``area``, so it is read here from the same YAML. A node with ``area: []`` (a corridor
waypoint) is not a room and gets no touch target; a node without ``area`` gets a small square.
Nodes sharing one area (a room's door and a node inside it) make ONE touch target, mapped to
the node that takes requests, else the tour stop, else the lowest id. Pure Python; no Qt.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import yaml

from interbot_core.topological_map import load_topological_map

logger = logging.getLogger(__name__)

DEFAULT_ROOM_SIZE = 2.0  # [m] side of the touch square of a node without an ``area``


class FloorPlanError(ValueError):
    """A topological map whose rooms cannot be shown (bad ``area``)."""


@dataclass(frozen=True)
class Room:
    """One touchable room: node id, texts, node pose [m] and outline [m]."""

    id: int
    name: str
    info: str
    x: float
    y: float
    tour: bool = False
    requests: bool = False
    home: bool = False
    area: tuple[tuple[float, float], ...] | None = None
    touchable: bool = True  # False for corridor waypoints (``area: []``) and merged nodes
    node_ids: tuple[int, ...] = ()  # every node drawn as this room (itself first)
    translations: tuple[tuple[str, str, str], ...] = ()  # (language, name, info)

    def in_language(self, language: str) -> Room:
        """This room with its ``name_<lang>`` / ``info_<lang>`` (English where missing)."""
        for lang, name, info in self.translations:
            if lang == language:
                return replace(self, name=name or self.name, info=info or self.info)
        return self

    def covers(self, node_id: int | None) -> bool:
        """True when ``node_id`` is this room's node or another node in the same area."""
        return node_id is not None and (node_id == self.id or node_id in self.node_ids)

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) [m] of the area, or a square around the node."""
        if self.area:
            xs = [p[0] for p in self.area]
            ys = [p[1] for p in self.area]
            return (min(xs), min(ys), max(xs), max(ys))
        half = DEFAULT_ROOM_SIZE / 2.0
        return (self.x - half, self.y - half, self.x + half, self.y + half)


@dataclass(frozen=True)
class FloorPlan:
    """Rooms in id order and the occupancy-grid YAML drawn under them (None if unknown)."""

    rooms: tuple[Room, ...]
    map_yaml: Path | None = None
    source: str = "<memory>"

    def in_language(self, language: str) -> FloorPlan:
        """The plan with every room's name and info in ``language`` (see `Room.in_language`)."""
        return replace(self, rooms=tuple(r.in_language(language) for r in self.rooms))

    def room(self, room_id: int) -> Room:
        for room in self.rooms:
            if room.id == room_id:
                return room
        raise KeyError(f"room {room_id} is not in {self.source}")

    def touch_rooms(self) -> tuple[Room, ...]:
        """The rooms shown on the map as touch targets."""
        return tuple(room for room in self.rooms if room.touchable)

    def name(self, room_id: int | None) -> str:
        if room_id is None:
            return "?"
        try:
            return self.room(room_id).name
        except KeyError:
            return f"#{room_id}"

    def bounds(self) -> tuple[float, float, float, float]:
        """The union of all room bounds [m]."""
        boxes = [room.bounds() for room in self.touch_rooms()]
        if not boxes:
            return (0.0, 0.0, 10.0, 10.0)
        return (
            min(b[0] for b in boxes),
            min(b[1] for b in boxes),
            max(b[2] for b in boxes),
            max(b[3] for b in boxes),
        )


def _parse_area(raw: Any, label: str, source: str) -> tuple[tuple[float, float], ...] | None:
    if raw is None:
        return None
    if raw == []:
        return ()
    if not isinstance(raw, list) or len(raw) < 3:
        raise FloorPlanError(
            f"{source}: {label}: 'area' must be a list of at least 3 [x, y] points, got {raw!r}"
        )
    points: list[tuple[float, float]] = []
    for i, point in enumerate(raw):
        ok = (
            isinstance(point, list | tuple)
            and len(point) == 2
            and all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in point
            )
        )
        if not ok:
            raise FloorPlanError(
                f"{source}: {label}: area[{i}] must be [x, y] finite numbers [m], got {point!r}"
            )
        points.append((float(point[0]), float(point[1])))
    return tuple(points)


TRANSLATED_LANGUAGES = ("pt",)


def _parse_translations(
    entry: Mapping[str, Any], label: str, source: str
) -> tuple[tuple[str, str, str], ...]:
    """``name_pt`` / ``info_pt`` of a node: strings of at most 200 / 1000 characters."""
    found = []
    for lang in TRANSLATED_LANGUAGES:
        name, info = entry.get(f"name_{lang}", ""), entry.get(f"info_{lang}", "")
        for key, value, limit in ((f"name_{lang}", name, 200), (f"info_{lang}", info, 1000)):
            if not isinstance(value, str) or len(value) > limit:
                raise FloorPlanError(
                    f"{source}: {label}: '{key}' must be text of at most {limit} characters"
                )
        if name or info:
            found.append((lang, name, info))
    return tuple(found)


def load_floor_plan(topo_path: str | Path) -> FloorPlan:
    """Rooms of a topological-map YAML, with their ``area`` outlines."""
    topo = load_topological_map(topo_path)
    source = str(topo_path)
    raw = yaml.safe_load(Path(topo_path).read_text(encoding="utf-8"))
    areas: dict[int, tuple[tuple[float, float], ...] | None] = {}
    translations: dict[int, tuple[tuple[str, str, str], ...]] = {}
    for entry in raw.get("nodes", []) if isinstance(raw, Mapping) else []:
        if isinstance(entry, Mapping) and "id" in entry:
            label = f"node {entry['id']!r}"
            areas[entry["id"]] = _parse_area(entry.get("area"), label, source)
            translations[entry["id"]] = _parse_translations(entry, label, source)
    nodes = sorted(topo.nodes, key=lambda n: n.id)
    groups: dict[tuple[tuple[float, float], ...], list[int]] = {}
    for node in nodes:
        area = areas.get(node.id)
        if area:
            groups.setdefault(area, []).append(node.id)
    by_id = {node.id: node for node in nodes}
    representative: dict[int, tuple[int, ...]] = {}
    for ids in groups.values():
        rep = min(ids, key=lambda i: (not by_id[i].requests, not by_id[i].tour, i))
        representative[rep] = (rep, *sorted(i for i in ids if i != rep))
    rooms = tuple(
        Room(
            id=node.id,
            name=node.name,
            info=node.info,
            x=node.pose.x,
            y=node.pose.y,
            tour=node.tour,
            requests=node.requests,
            home=node.home,
            area=areas.get(node.id) or None,
            touchable=(
                node.id in representative if areas.get(node.id) else areas.get(node.id) is None
            ),
            node_ids=representative.get(node.id, (node.id,)),
            translations=translations.get(node.id, ()),
        )
        for node in nodes
    )
    logger.info("floor plan %s: %d rooms", source, len(rooms))
    return FloorPlan(rooms, topo.map_yaml_path, source)
