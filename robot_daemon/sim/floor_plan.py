"""Floor plans: an editable YAML description of an office floor, rasterised to an occupancy grid.

The thesis's Tablet and Base Station work on an *a priori* map of ISR floor 0 (thesis §5.2.1.1,
Algorithm 3: a 70 m x 35 m frame with x in [-35, 35], y in [-14.25, 20.75]) and on a topological
map whose nodes stand at the entrance of every room, or inside the rooms that take requests
(§5.2.2, §6.2). Both are drawn from one floor plan (``maps/isr_floor0_plan.yaml``), which is also
the simulated building's source (`robot_daemon.sim.realistic_world` draws it again, perturbed):

* :func:`parse_floor_plan` / :func:`load_floor_plan` validate the plan (declared by `PlanFile`,
  msgspec) into a `FloorPlan`; every error names the room (or corridor, door, node), the
  field, the value and what is allowed;
* :func:`rasterise` draws it into an :class:`~interbot_core.occupancy_grid.OccupancyGrid`
  (building = occupied, floors of rooms/corridors and door openings = free, furniture = occupied,
  outside and courtyards = unknown), so walls are the gaps between floor rectangles.

The map files themselves (the grid and the topological map with its nodes, arcs and room
outlines) are written by the authoring tool ``tools/generate_isr_map.py``, not by the robot.
Pure: no I/O except :func:`load_floor_plan`.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import msgspec
import numpy as np
from msgspec import Meta

from interbot_core import schema
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from interbot_core.schema import SchemaError

logger = logging.getLogger(__name__)

DOOR_WIDTH_MIN = 0.9  # [m]
DOOR_WIDTH_MAX = 1.2  # [m]
WALL_MIN = 0.1  # [m] floors (rooms, corridors) must be at least this far apart
WALL_MAX = 0.5  # [m] a door may cross at most this much wall to reach a corridor
DOOR_JAMB = 0.1  # [m] minimum wall left between a door and the room's corner
DOOR_APPROACH_DEPTH = 1.0  # [m] furniture-free depth inside the room in front of a door
DOOR_APPROACH_SIDE = 0.3  # [m] furniture-free margin either side of the door
WALLS = ("north", "south", "east", "west")


# The plan file, declared (msgspec): types carry the rules a single value can break; the geometry
# across items is `validate_floor_plan`'s.
Name = Annotated[str, Meta(pattern=r"\S", extra={"format": "a non-empty string"})]
Span = tuple[schema.Finite, schema.Finite]  # [min, max] along one axis [m]
Metres = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "m"})]
Text = Annotated[str | None, Meta(extra={"format": "a string"})]


class FloorPlanError(ValueError):
    """A floor plan is malformed or inconsistent; the message names the file, item and field."""


# ---------------------------------------------------------------------------- value types


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in the map frame [m], ``x0 < x1`` and ``y0 < y1``."""

    x0: float
    y0: float
    x1: float
    y1: float

    def __post_init__(self) -> None:
        values = (self.x0, self.y0, self.x1, self.y1)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"rectangle coordinates must be finite, got {values}")
        if not (self.x0 < self.x1 and self.y0 < self.y1):
            raise ValueError(
                f"rectangle needs x_min < x_max and y_min < y_max, got "
                f"x [{self.x0}, {self.x1}], y [{self.y0}, {self.y1}]"
            )

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0

    def contains(self, other: Rect, tol: float = 1e-9) -> bool:
        """True if ``other`` lies inside this rectangle (touching the edges allowed)."""
        return (
            other.x0 >= self.x0 - tol
            and other.x1 <= self.x1 + tol
            and other.y0 >= self.y0 - tol
            and other.y1 <= self.y1 + tol
        )

    def contains_point(self, x: float, y: float, tol: float = 1e-9) -> bool:
        return self.x0 - tol <= x <= self.x1 + tol and self.y0 - tol <= y <= self.y1 + tol

    def overlaps(self, other: Rect, gap: float = 0.0) -> bool:
        """True if the rectangles come closer than ``gap`` [m] (overlap when gap is 0)."""
        tol = 1e-9
        return (
            self.x0 < other.x1 + gap - tol
            and other.x0 < self.x1 + gap - tol
            and self.y0 < other.y1 + gap - tol
            and other.y0 < self.y1 + gap - tol
        )

    def polygon(self) -> list[list[float]]:
        """The corners counter-clockwise from the south-west one, as ``[[x, y], ...]``."""
        return [
            [self.x0, self.y0],
            [self.x1, self.y0],
            [self.x1, self.y1],
            [self.x0, self.y1],
        ]


class _Entry(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    pass


class Door(_Entry, frozen=True):
    """A door in one wall of a room: ``offset`` [m] from the wall's west/south end to its centre
    (its fields checked as the plan is read, not when built in Python)."""

    wall: Annotated[str, schema.one_of(*WALLS)]
    offset: schema.Finite  # [m]
    # [m] (1e-9: a width computed as 1.2000000000000002 is 1.2)
    width: Annotated[
        float, Meta(ge=DOOR_WIDTH_MIN - 1e-9, le=DOOR_WIDTH_MAX + 1e-9, extra={"unit": "m"})
    ]


class _PointEntry(_Entry, frozen=True):
    x: schema.Finite  # [m]
    y: schema.Finite  # [m]


class Waypoint(_PointEntry, frozen=True):
    """A corridor junction node that is not a room (tour: false)."""

    name: Name


# ---------------------------------------------------------------------------- parsing


class _RectEntry(_Entry, frozen=True):
    x: Span
    y: Span

    @property
    def rect(self) -> Rect:
        return Rect(self.x[0], self.y[0], self.x[1], self.y[1])


class Area(_RectEntry, frozen=True):
    """A named rectangle: a corridor floor or a courtyard."""

    name: Name


class Furniture(_RectEntry, frozen=True):
    """An obstacle inside a room (table, shelf, bench), drawn as occupied."""

    name: Name = "furniture"


class Room(_RectEntry, frozen=True):
    """A room: its free floor rectangle, doors, furniture and what the tablet shows (the texts
    may be None: not given)."""

    name: Name
    doors: Annotated[tuple[Door, ...], Meta(min_length=1)]  # at least one to a corridor
    furniture: tuple[Furniture, ...] = ()
    info: Text = ""
    info_pt: Text = ""  # the tablet's Portuguese texts (empty: the English one is shown)
    name_pt: Text = ""
    tour: bool = False
    requests: bool = False
    home: bool = False
    inside: _PointEntry | None = None  # [m] node inside the room (request rooms)


class _MapEntry(_Entry, frozen=True):
    resolution: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "m/cell"})]
    origin: Span
    size: tuple[Metres, Metres]  # [m] width (x), height (y)


class _OutputsEntry(_Entry, frozen=True):
    map: Name
    topological: Name


class PlanFile(_Entry, frozen=True):
    """The floor-plan YAML (see ``maps/isr_floor0_plan.yaml`` for every key)."""

    map: _MapEntry
    outputs: _OutputsEntry
    building: _RectEntry
    name: Name = "floor plan"
    entrance_distance: Metres = 0.9
    arc_clearance: Metres = 0.3
    node_clearance: Metres = 0.35
    corridors: tuple[Area, ...] = ()
    courtyards: tuple[Area, ...] = ()
    waypoints: tuple[Waypoint, ...] = ()
    rooms: tuple[Room, ...] = ()
    ring: tuple[Name, ...] = ()
    arcs: tuple[
        Annotated[tuple[Name, ...], Meta(min_length=2, extra={"format": "a chain of node names"})],
        ...,
    ] = ()


class FloorPlan(PlanFile, frozen=True):
    """A validated floor plan: the file's entries and the file they came from. Build it with
    :func:`parse_floor_plan`."""

    source: str = "<memory>"

    @property
    def shape(self) -> tuple[int, int]:
        """Grid (rows, cols)."""
        (width, height), resolution = self.map.size, self.map.resolution
        return round(height / resolution), round(width / resolution)

    @property
    def map_rect(self) -> Rect:
        (x, y), (width, height) = self.map.origin, self.map.size
        return Rect(x, y, x + width, y + height)

    def room(self, name: str) -> Room:
        """The room called ``name``."""
        for room in self.rooms:
            if room.name == name:
                return room
        raise FloorPlanError(f"{self.source}: no room named {name!r}")


def _room_label(data: Any, path: str) -> str:
    """``room 'Bar': `` for an error inside ``rooms[i]`` whose name can be read."""
    found = re.match(r"rooms\[(\d+)\]", path)
    rooms = data.get("rooms") if isinstance(data, Mapping) else None
    if found is None or not isinstance(rooms, list) or int(found[1]) >= len(rooms):
        return ""
    raw = rooms[int(found[1])]
    return f"room {raw['name']!r}: " if isinstance(raw, Mapping) and "name" in raw else ""


def parse_floor_plan(data: Any, source: str = "<memory>") -> FloorPlan:
    """Validate parsed plan YAML ``data`` into a :class:`FloorPlan`.

    Raises :class:`FloorPlanError` naming ``source``, the room / corridor / door and the field.
    """
    try:
        top = schema.convert(data, PlanFile, "")
    except SchemaError as exc:
        message = exc.key_message()
        raise FloorPlanError(f"{source}: {_room_label(data, exc.path)}{message}") from None
    rect_of: list[tuple[str, _RectEntry]] = [("building", top.building)]
    rect_of += [(f"corridor {a.name!r}", a) for a in top.corridors]
    rect_of += [(f"courtyard {a.name!r}", a) for a in top.courtyards]
    for room in top.rooms:
        rect_of.append((f"room {room.name!r}", room))
        rect_of += [(f"room {room.name!r} furniture ({f.name})", f) for f in room.furniture]
    for label, entry in rect_of:
        try:
            entry.rect  # noqa: B018 (built to be checked)
        except ValueError as exc:
            raise FloorPlanError(f"{source}: {label}: 'x'/'y': {exc}") from None
    plan = FloorPlan(**msgspec.structs.asdict(top), source=source)
    validate_floor_plan(plan)
    return plan


def load_floor_plan(path: str | Path) -> FloorPlan:
    """Read and validate a floor-plan YAML file."""
    source = str(path)
    plan = parse_floor_plan(schema.read_yaml(path, FloorPlanError, "floor plan"), source)
    logger.info(
        "loaded floor plan %s: %d rooms, %d corridors, %d nodes",
        source,
        len(plan.rooms),
        len(plan.corridors),
        len(plan.ring),
    )
    return plan


# ---------------------------------------------------------------------------- validation


def validate_floor_plan(plan: FloorPlan) -> None:
    """Check the geometry and the node lists of ``plan``; raise :class:`FloorPlanError`."""
    src = plan.source
    building = plan.building.rect
    if not plan.map_rect.contains(building):
        raise FloorPlanError(f"{src}: building: outline {building} leaves the map frame")
    names = [room.name for room in plan.rooms]
    for name in names:
        if names.count(name) > 1:
            raise FloorPlanError(f"{src}: room {name!r}: the name is used twice")
    floors = [(f"corridor {c.name!r}", c.rect) for c in plan.corridors]
    floors += [(f"room {r.name!r}", r.rect) for r in plan.rooms]
    for label, rect in floors + [(f"courtyard {c.name!r}", c.rect) for c in plan.courtyards]:
        if not building.contains(rect):
            raise FloorPlanError(f"{src}: {label}: 'x'/'y' lie outside the building outline")
    # Rooms keep a wall to every other floor and courtyard; corridors may overlap each other.
    others = floors + [(f"courtyard {c.name!r}", c.rect) for c in plan.courtyards]
    for room in plan.rooms:
        for label, rect in others:
            if label == f"room {room.name!r}":
                continue
            if room.rect.overlaps(rect, WALL_MIN):
                raise FloorPlanError(
                    f"{src}: room {room.name!r}: 'x'/'y' overlap {label} or leave less than "
                    f"{WALL_MIN} m of wall to it"
                )
    for court in plan.courtyards:
        for corridor in plan.corridors:
            if court.rect.overlaps(corridor.rect, WALL_MIN):
                raise FloorPlanError(
                    f"{src}: courtyard {court.name!r}: overlaps corridor {corridor.name!r}"
                )
    homes = [room.name for room in plan.rooms if room.home]
    if len(homes) != 1:
        raise FloorPlanError(f"{src}: exactly one room needs home: true, found {homes}")
    for room in plan.rooms:
        _validate_room(plan, room)


def _validate_room(plan: FloorPlan, room: Room) -> None:
    src = plan.source
    label = f"room {room.name!r}"
    for index in range(len(room.doors)):
        door_opening(plan, room, index)  # raises when the door does not reach a corridor
        zone = door_approach_zone(room, index)
        for f, item in enumerate(room.furniture):
            if item.rect.overlaps(zone):
                raise FloorPlanError(
                    f"{src}: {label} furniture[{f}] ({item.name}): blocks doors[{index}]; keep "
                    f"{DOOR_APPROACH_DEPTH} m in front of a door and {DOOR_APPROACH_SIDE} m "
                    "either side free"
                )
    for f, item in enumerate(room.furniture):
        if not room.rect.contains(item.rect):
            raise FloorPlanError(
                f"{src}: {label} furniture[{f}] ({item.name}): 'x'/'y' must lie inside the room "
                f"x [{room.rect.x0}, {room.rect.x1}], y [{room.rect.y0}, {room.rect.y1}]"
            )
    if room.requests and room.inside is None:
        raise FloorPlanError(
            f"{src}: {label}: a room with requests: true needs 'inside: {{x, y}}', the node "
            "inside the room where requests are handed over"
        )
    if room.inside is not None:
        x, y = room.inside.x, room.inside.y
        if not room.rect.contains_point(x, y):
            raise FloorPlanError(f"{src}: {label}: 'inside' ({x}, {y}) lies outside the room")
        for f, item in enumerate(room.furniture):
            if item.rect.contains_point(x, y):
                raise FloorPlanError(
                    f"{src}: {label}: 'inside' ({x}, {y}) lies on furniture[{f}] ({item.name})"
                )


# ---------------------------------------------------------------------------- geometry


def _wall_axis(room: Room, wall: str) -> tuple[float, float]:
    """(start, end) of a wall along its own direction [m]: x for north/south, y for east/west."""
    if wall in ("north", "south"):
        return room.rect.x0, room.rect.x1
    return room.rect.y0, room.rect.y1


def door_opening(plan: FloorPlan, room: Room, index: int) -> Rect:
    """The opening (free rectangle, room face to corridor face) that ``room.doors[index]`` cuts
    through the wall to the nearest corridor."""
    door = room.doors[index]
    label = f"{plan.source}: room {room.name!r} doors[{index}]"
    start, end = _wall_axis(room, door.wall)
    centre = start + door.offset
    lo, hi = centre - door.width / 2, centre + door.width / 2
    if lo < start + DOOR_JAMB - 1e-9 or hi > end - DOOR_JAMB + 1e-9:
        raise FloorPlanError(
            f"{label}: 'offset' {door.offset} puts the door outside the {door.wall} wall; allowed "
            f"{DOOR_JAMB + door.width / 2:.2f}..{end - start - DOOR_JAMB - door.width / 2:.2f} m"
        )
    r = room.rect
    best: tuple[float, Area] | None = None
    for corridor in plan.corridors:
        c = corridor.rect
        if door.wall == "north":
            gap, covers = c.y0 - r.y1, c.x0 <= lo and hi <= c.x1
        elif door.wall == "south":
            gap, covers = r.y0 - c.y1, c.x0 <= lo and hi <= c.x1
        elif door.wall == "east":
            gap, covers = c.x0 - r.x1, c.y0 <= lo and hi <= c.y1
        else:
            gap, covers = r.x0 - c.x1, c.y0 <= lo and hi <= c.y1
        if covers and 0.0 < gap <= WALL_MAX + 1e-9 and (best is None or gap < best[0]):
            best = (gap, corridor)
    if best is None:
        raise FloorPlanError(
            f"{label}: the {door.wall} wall at 'offset' {door.offset} does not open onto a "
            f"corridor (none within {WALL_MAX} m covering the door's full width)"
        )
    gap = best[0]
    if door.wall == "north":
        return Rect(lo, r.y1, hi, r.y1 + gap)
    if door.wall == "south":
        return Rect(lo, r.y0 - gap, hi, r.y0)
    if door.wall == "east":
        return Rect(r.x1, lo, r.x1 + gap, hi)
    return Rect(r.x0 - gap, lo, r.x0, hi)


def door_approach_zone(room: Room, index: int) -> Rect:
    """The furniture-free rectangle inside ``room`` in front of ``room.doors[index]``."""
    door = room.doors[index]
    start, _ = _wall_axis(room, door.wall)
    half = door.width / 2 + DOOR_APPROACH_SIDE
    c = start + door.offset
    r, depth = room.rect, DOOR_APPROACH_DEPTH
    if door.wall == "north":
        return Rect(c - half, r.y1 - depth, c + half, r.y1)
    if door.wall == "south":
        return Rect(c - half, r.y0, c + half, r.y0 + depth)
    if door.wall == "east":
        return Rect(r.x1 - depth, c - half, r.x1, c + half)
    return Rect(r.x0, c - half, r.x0 + depth, c + half)


# ---------------------------------------------------------------------------- rasterising


def _cell_border(distance: float, resolution: float) -> int:
    """Index of the cell border nearest to ``distance`` [m]; halves round up (both edges alike,
    so a rectangle a whole number of cells wide keeps that width wherever it starts)."""
    return math.floor(distance / resolution + 0.5 + 1e-6)


def _cell_slices(plan: FloorPlan, rect: Rect) -> tuple[slice, slice]:
    """Rows and columns of the cells inside ``rect``, its edges snapped to cell borders."""
    rows, cols = plan.shape
    (x, y), resolution = plan.map.origin, plan.map.resolution
    c0 = _cell_border(rect.x0 - x, resolution)
    c1 = _cell_border(rect.x1 - x, resolution)
    r0 = _cell_border(rect.y0 - y, resolution)
    r1 = _cell_border(rect.y1 - y, resolution)
    return (
        slice(min(max(r0, 0), rows), min(max(r1, 0), rows)),
        slice(min(max(c0, 0), cols), min(max(c1, 0), cols)),
    )


def rasterise(plan: FloorPlan) -> OccupancyGrid:
    """Draw ``plan`` into an occupancy grid (row 0 at the bottom).

    Order: unknown everywhere; building outline occupied; courtyards unknown; corridor and room
    floors free; door openings free; furniture occupied. Rectangle edges snap to cell borders.
    """
    cells = np.full(plan.shape, UNKNOWN, dtype=np.int8)
    cells[_cell_slices(plan, plan.building.rect)] = OCCUPIED
    for court in plan.courtyards:
        cells[_cell_slices(plan, court.rect)] = UNKNOWN
    for corridor in plan.corridors:
        cells[_cell_slices(plan, corridor.rect)] = FREE
    for room in plan.rooms:
        cells[_cell_slices(plan, room.rect)] = FREE
    for room in plan.rooms:
        for index in range(len(room.doors)):
            cells[_cell_slices(plan, door_opening(plan, room, index))] = FREE
    for room in plan.rooms:
        for item in room.furniture:
            cells[_cell_slices(plan, item.rect)] = OCCUPIED
    return OccupancyGrid(cells, plan.map.resolution, *plan.map.origin, source=plan.name)
