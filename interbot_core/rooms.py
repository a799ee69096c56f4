"""The rooms of a floor: one model for the Tablet's map and the Base Station's map.

The Tablet shows the rooms as touch targets (thesis §5.2.1, Appendix I Figs. 1 and 3: each room
"directly linked to a button"); the Base Station shows them on its map, labelled, and a click in
one selects its node for a task (§5.3 "Tasks"). Both read the rooms here, with one set of rules.

Rooms come from the topological-map YAML (`interbot_core.topological_map`). The loader there
ignores extra node keys; these are read here and nowhere else:

* ``area``: the room's floor outline ``[[x, y], ...]`` [m] in the ``map`` frame (at least three
  points). ``area: []`` marks a node that is no room (a corridor waypoint); a node without
  ``area`` gets a square of ``DEFAULT_ROOM_SIZE`` around it (maps drawn without outlines).
* ``kind``: ``entrance``, ``inside`` or ``waypoint``; a waypoint is no room either.
* ``name_<lang>`` / ``info_<lang>`` (``pt``): the room's name and text in another language.
* ``room`` (the room's name) is written by the map generator for people reading the file.

**One room, one node.** Nodes with the same ``area`` are one room (a room's door node in the
corridor and the node inside it). A touch or click on the room selects ONE node, the room's
own: the node that takes requests, else a tour stop, else an ``inside`` node, else the lowest
id. **Where a click lands** (`RoomMap.room_at`): the room whose outline contains the point (an
outline from the file before a default square, then the room whose node is nearest), else the
room with a node within ``snap_radius`` (the station's clicks on a door node in the corridor).
**Labels** sit on each room's clearest floor (`clearest_point`: the pole of inaccessibility of
the free cells of the occupancy grid inside the outline) when the grid is known, else at the
outline's centroid. Pure: no Qt; reading the file is the only I/O (`load_room_map`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any

import msgspec
import numpy as np
import numpy.typing as npt
from scipy import ndimage

from interbot_core import schema
from interbot_core.occupancy_grid import FREE, OccupancyGrid
from interbot_core.topological_map import (
    TopologicalMap,
    TopologicalMapError,
    load_topological_map,
)

logger = logging.getLogger(__name__)

DEFAULT_ROOM_SIZE = 2.0  # [m] side of the square room of a node without an ``area``
TRANSLATED_LANGUAGES = ("pt",)
KINDS = ("entrance", "inside", "waypoint")
NAME_MAX, INFO_MAX = 200, 1000  # [characters] of a translated name / info

Point = tuple[float, float]
Metres = Annotated[float, msgspec.Meta(ge=-schema.FINITE, le=schema.FINITE, extra={"unit": "m"})]


class RoomMapError(TopologicalMapError):
    """A topological map whose rooms cannot be drawn (bad ``area``, ``kind`` or translation)."""


class RoomKeys(msgspec.Struct, frozen=True):
    """The room keys of one ``nodes:`` entry (its other keys are the topological map's)."""

    kind: Annotated[str, schema.one_of(*KINDS)] | None = None  # None: entrance
    area: tuple[tuple[Metres, Metres], ...] | None = None  # None: a square; (): no room
    name_pt: Annotated[str, msgspec.Meta(max_length=NAME_MAX)] = ""
    info_pt: Annotated[str, msgspec.Meta(max_length=INFO_MAX)] = ""

    def outline(self, label: str, node: Point) -> tuple[Point, ...]:
        """The room's outline: ``()`` for ``[]``, a square around ``node`` without ``area``."""
        if self.area is None:
            x, y, h = node[0], node[1], DEFAULT_ROOM_SIZE / 2.0
            return ((x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h))
        if 0 < len(self.area) < 3:
            raise RoomMapError(
                f"{label}: area must be [] or a list of at least 3 [x, y] points [m], "
                f"got {len(self.area)}"
            )
        return self.area

    def translations(self) -> tuple[tuple[str, str, str], ...]:
        """``(language, name, info)`` of each language with a ``name_<lang>``/``info_<lang>``."""
        texts = (
            (lang, getattr(self, f"name_{lang}"), getattr(self, f"info_{lang}"))
            for lang in TRANSLATED_LANGUAGES
        )
        return tuple(t for t in texts if t[1] or t[2])


@dataclass(frozen=True)
class Texts:
    """A node's name and info text, and their translations ``(language, name, info)``."""

    name: str
    info: str
    translations: tuple[tuple[str, str, str], ...] = ()

    def in_language(self, language: str) -> Texts:
        for lang, name, info in self.translations:
            if lang == language:
                return replace(self, name=name or self.name, info=info or self.info)
        return self


@dataclass(frozen=True)
class Room:
    """One room: the outline a user touches or clicks and the node that this means.

    ``id`` is the room's own node (the goal a touch on the room sends); ``node_ids`` every node
    drawn as this room, ``id`` first; ``name`` and ``info`` are the own node's, in the map's
    current language; ``label`` [m] is where the name is written.
    """

    id: int
    node_ids: tuple[int, ...]
    name: str
    info: str
    area: tuple[Point, ...]
    label: Point
    explicit: bool = True  # False: the default square around a node without ``area``
    tour: bool = False
    requests: bool = False
    home: bool = False

    def covers(self, node_id: int | None) -> bool:
        """True when ``node_id`` is one of this room's nodes."""
        return node_id is not None and node_id in self.node_ids

    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) [m] lies inside the outline (even-odd rule)."""
        return point_in_polygon(x, y, self.area)

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) [m] of the outline."""
        xs = [p[0] for p in self.area]
        ys = [p[1] for p in self.area]
        return (min(xs), min(ys), max(xs), max(ys))

    @property
    def width(self) -> float:
        """[m] along x: the room a label has."""
        x0, _, x1, _ = self.bounds()
        return x1 - x0


@dataclass(frozen=True)
class RoomMap:
    """The rooms of a topological map in the order of their nodes, and every node's texts."""

    topo: TopologicalMap
    rooms: tuple[Room, ...]
    texts: tuple[Texts, ...]  # per node id, in every language
    language: str = "en"

    def in_language(self, language: str) -> RoomMap:
        """The same rooms with names and infos in ``language`` (English where none is given)."""
        rooms = []
        for room in self.rooms:
            texts = self.texts[room.id].in_language(language)
            rooms.append(replace(room, name=texts.name, info=texts.info))
        return replace(self, rooms=tuple(rooms), language=language)

    def room(self, node_id: int) -> Room:
        """The room drawn for ``node_id`` (its own node or another node in it)."""
        for room in self.rooms:
            if room.covers(node_id):
                return room
        raise KeyError(f"node {node_id} is in no room of {self.topo.source}")

    def in_a_room(self, node_id: int) -> bool:
        """False for corridor waypoints (and ids that are not nodes)."""
        return any(room.covers(node_id) for room in self.rooms)

    def name(self, node_id: int | None) -> str:
        """The name of any node, room or not, in the current language."""
        if node_id is None:
            return "?"
        if isinstance(node_id, bool) or not 0 <= node_id < len(self.texts):
            return f"#{node_id}"
        return self.texts[node_id].in_language(self.language).name

    def node_xy(self, node_id: int) -> Point | None:
        """The node's position [m], or None if there is no such node."""
        if isinstance(node_id, bool) or not 0 <= node_id < len(self.topo.nodes):
            return None
        pose = self.topo.nodes[node_id].pose
        return (pose.x, pose.y)

    def room_at(self, x: float, y: float, snap_radius: float = 0.0) -> Room | None:
        """The room a touch or click at (x, y) [m] selects, or None (see the module docstring)."""
        hits = [room for room in self.rooms if room.contains(x, y)]
        if hits:
            return min(hits, key=lambda r: (not r.explicit, self._distance(r, x, y), r.id))
        best: tuple[float, Room] | None = None
        for room in self.rooms:
            d = self._distance(room, x, y)
            if snap_radius > 0.0 and d <= snap_radius and (best is None or d < best[0]):
                best = (d, room)
        return None if best is None else best[1]

    def _distance(self, room: Room, x: float, y: float) -> float:
        """[m] from (x, y) to the nearest node of ``room``."""
        poses = (self.topo.nodes[i].pose for i in room.node_ids)
        return min(math.hypot(p.x - x, p.y - y) for p in poses)

    def with_labels(self, grid: OccupancyGrid) -> RoomMap:
        """The rooms with each label on its clearest floor in ``grid`` (see `clearest_point`)."""
        rooms = []
        for room in self.rooms:
            spot = clearest_point(room.area, grid) if room.explicit else None
            rooms.append(room if spot is None else replace(room, label=spot))
        return replace(self, rooms=tuple(rooms))

    def bounds(self) -> tuple[float, float, float, float]:
        """The union of all room outlines [m] (a 10 m square at the origin without rooms)."""
        boxes = [room.bounds() for room in self.rooms]
        if not boxes:
            return (0.0, 0.0, 10.0, 10.0)
        return (
            min(b[0] for b in boxes),
            min(b[1] for b in boxes),
            max(b[2] for b in boxes),
            max(b[3] for b in boxes),
        )


# ---------------------------------------------------------------------------- building


def load_room_map(path: str | Path, topo: TopologicalMap | None = None) -> RoomMap:
    """The rooms of a topological-map YAML file (``topo``: the map already loaded from it)."""
    if topo is None:
        topo = load_topological_map(path)
    rooms = room_map(topo, schema.read_yaml(path, RoomMapError, "rooms"))
    logger.info("rooms of %s: %d rooms", path, len(rooms.rooms))
    return rooms


def room_map(topo: TopologicalMap, raw: Any = None) -> RoomMap:
    """The rooms of ``topo`` from its parsed YAML ``raw`` (None: no extra keys, every node a
    default square). Raises `RoomMapError` naming the file, the node and the key."""
    entries: dict[int, Mapping[str, Any]] = {}
    raw_nodes = raw.get("nodes") if isinstance(raw, Mapping) else None
    for entry in raw_nodes if isinstance(raw_nodes, list) else []:
        if isinstance(entry, Mapping) and isinstance(entry.get("id"), int):
            entries[entry["id"]] = entry
    texts: list[Texts] = []
    outlines: list[tuple[Point, ...] | None] = []  # None: no room
    kinds: list[str] = []
    for node in topo.nodes:
        label = f"{topo.source}: node {node.id}"
        try:
            keys = schema.convert(entries.get(node.id, {}), RoomKeys, "")
        except schema.SchemaError as exc:
            raise RoomMapError(f"{label}: {exc.message}") from None
        kind = keys.kind or "entrance"
        area = keys.outline(label, (node.pose.x, node.pose.y))
        kinds.append(kind)
        outlines.append(None if kind == "waypoint" or area == () else area)
        texts.append(Texts(node.name, node.info, keys.translations()))
    explicit = {node.id: entries.get(node.id, {}).get("area") is not None for node in topo.nodes}
    groups: dict[tuple[Point, ...], list[int]] = {}
    for node in topo.nodes:
        outline = outlines[node.id]
        if outline is not None:
            groups.setdefault(outline, []).append(node.id)
    rooms = []
    for outline, ids in groups.items():
        nodes = [topo.nodes[i] for i in ids]
        own = min(nodes, key=lambda n: (not n.requests, not n.tour, kinds[n.id] != "inside", n.id))
        rooms.append(
            Room(
                id=own.id,
                node_ids=(own.id, *sorted(i for i in ids if i != own.id)),
                name=own.name,
                info=own.info,
                area=outline,
                label=polygon_centroid(outline),
                explicit=explicit[own.id],
                tour=own.tour,
                requests=own.requests,
                home=own.home,
            )
        )
    rooms.sort(key=lambda r: r.id)
    return RoomMap(topo, tuple(rooms), tuple(texts))


# ---------------------------------------------------------------------------- geometry


def point_in_polygon(x: float, y: float, polygon: Sequence[Point]) -> bool:
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


def polygon_centroid(polygon: Sequence[Point]) -> Point:
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


def clearest_point(polygon: Sequence[Point], grid: OccupancyGrid) -> Point | None:
    """The free cell inside ``polygon`` farthest from anything that is not free (furniture,
    walls, unknown), ties broken towards the centroid; None if no free cell is inside.

    A pole of inaccessibility on the map's free space: ``scipy.ndimage.distance_transform_edt``
    of the free mask over the polygon's bounding box, masked to the polygon (even-odd rule).
    """
    xs = np.array([p[0] for p in polygon])
    ys = np.array([p[1] for p in polygon])
    c0 = max(0, int((xs.min() - grid.origin_x) / grid.resolution))
    c1 = min(grid.width - 1, int((xs.max() - grid.origin_x) / grid.resolution))
    r0 = max(0, int((ys.min() - grid.origin_y) / grid.resolution))
    r1 = min(grid.height - 1, int((ys.max() - grid.origin_y) / grid.resolution))
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


def _inside(
    px: npt.NDArray[np.float64],
    py: npt.NDArray[np.float64],
    xs: npt.NDArray[np.float64],
    ys: npt.NDArray[np.float64],
) -> npt.NDArray[np.bool_]:
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
