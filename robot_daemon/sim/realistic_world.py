"""A simulated building that is *not* the robot's map: the map's source, drawn again, perturbed.

The robot localises and plans on its a-priori map (``OccupancyGrid``, 5 cm cells). A real
building differs from its map: walls were drawn or mapped a few centimetres off, furniture moved
or was added, some doors are shut that were open when the map was made (and the other way round),
glass reflects or lets the laser through. If the simulator traced its laser in the very grid the
localiser matches against, every localisation figure would be a best case (issue 12). This module
builds the simulator's own world, deterministic for a seed:

* **From a floor plan** (``maps/<name>_plan.yaml`` beside the map, the ISR floor's source): the
  plan is drawn again at ``resolution`` (2 cm) with every room displaced by ``N(0, wall_sigma)``
  in x and y, so walls lie off the map's by a few centimetres and off its 5 cm lattice; ``doors_closed`` doors the map has open are shut (never of a room with a
  node inside it), ``doors_opened`` doors the map does not have are cut; ``tables_moved`` pieces
  of furniture stand 0.3-0.6 m from where the map has them; ``glass_panels`` wall sections facing
  a corridor are glass (solid to the robot, transparent to the laser but at near-normal
  incidence; see ``laser_sim``).
* **From an occupancy grid** (the real maps, Willow Garage and Fetch): the grid is upsampled to
  ``resolution`` and warped by a smooth random displacement field (independent ``N(0,
  wall_sigma)`` x/y offsets on a ``warp_length`` lattice, bicubic in between), so whole rooms
  and walls shift by a few centimetres relative to the map.
* **Clutter** on both: ``boxes`` boxes (0.3-0.6 m, any yaw) and ``chairs`` chairs (four 3 cm
  legs on a 0.42 m square: the laser sees legs, not a seat) in rooms, and ``corridor_items``
  boxes against corridor walls. Items keep ``route_clearance`` from every topological arc and
  ``node_clearance`` from every node, so the building stays passable where the graph says it is;
  elsewhere they may narrow a passage, as furniture does.

Unknown cells of the source are walls in the world (the conservative reading of an unexplored
region). The robot never sees this module's output except through its simulated sensors.
"""

from __future__ import annotations

import logging
import math
import typing
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, ClassVar

import cv2
import msgspec
import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from interbot_core.schema import within
from interbot_core.topological_map import TopologicalMap
from robot_daemon.sim.floor_plan import (
    Door,
    FloorPlan,
    FloorPlanError,
    Furniture,
    Rect,
    Room,
    door_approach_zone,
    door_opening,
    load_floor_plan,
    rasterise,
)

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
Placed = typing.TypeVar("Placed", Room, Furniture)

CHAIR_SIDE = 0.42  # [m] leg square of an office chair
CHAIR_LEG = 0.03  # [m] leg (or castor column) width
_PLACEMENT_TRIES = 400


class WorldVariationError(ValueError):
    """A world-variation parameter is out of range; the message names it."""


Count = Annotated[int, Meta(ge=0, le=200)]
Clearance = Annotated[float, within(0.0, 5.0, "m")]


class WorldVariation(schema.Declared, frozen=True):
    """How far the simulated building departs from the map (defaults: issue 12's figures)."""

    ROOT: ClassVar[str] = "WorldVariation"
    ERROR: ClassVar[type[Exception]] = WorldVariationError

    resolution: Annotated[float, within(0.005, 0.05, "m")] = 0.02  # cell of the world's drawing
    # room / wall displacement, per axis (~5 cm in 2-D)
    wall_sigma: Annotated[float, within(0.0, 0.2, "m")] = 0.035
    # lattice of the displacement field (grid sources)
    warp_length: Annotated[float, within(0.5, 50.0, "m")] = 4.0
    boxes: Count = 6
    chairs: Count = 6
    corridor_items: Count = 4
    tables_moved: Count = 1
    doors_closed: Count = 1
    doors_opened: Count = 1
    glass_panels: Count = 2
    route_clearance: Clearance = 0.65  # clutter keeps this far from topological arcs
    node_clearance: Clearance = 1.0  # clutter keeps this far from topological nodes


@dataclass(frozen=True)
class Item:
    """A piece of clutter: an oriented rectangle [m] (centre, size along its axes, yaw)."""

    kind: str  # box | chair-leg | corridor box
    center_x: float
    center_y: float
    size_x: float
    size_y: float
    yaw: float = 0.0


@dataclass(frozen=True)
class SimWorldSpec:
    """The simulator's building: its own grid, glass, clutter and what differs from the map."""

    grid: OccupancyGrid  # walls and furniture at ``resolution`` (unknown = wall)
    glass: tuple[Rect, ...]  # panes: solid to the robot, mostly transparent to the laser
    items: tuple[Item, ...]
    notes: tuple[str, ...]  # human-readable list of the differences (logged)

    def describe(self) -> str:
        return "; ".join(self.notes)


# ---------------------------------------------------------------------------- floor plans


def plan_beside(map_yaml: Path) -> Path | None:
    """The floor plan ``<stem>_plan.yaml`` next to a map YAML, if there is one."""
    candidate = map_yaml.with_name(f"{map_yaml.stem}_plan.yaml")
    return candidate if candidate.exists() else None


def _shifted(item: Placed, dx: float, dy: float) -> Placed:
    """A room or a piece of furniture moved by (dx, dy) [m]."""
    x, y = item.x, item.y
    return msgspec.structs.replace(item, x=(x[0] + dx, x[1] + dx), y=(y[0] + dy, y[1] + dy))


def _opens(plan: FloorPlan, room: Room) -> bool:
    try:
        for i in range(len(room.doors)):
            door_opening(plan, room, i)
    except FloorPlanError:
        return False
    return True


def _displace_plan(
    plan: FloorPlan, rng: np.random.Generator, sigma: float
) -> tuple[FloorPlan, float]:
    """Rooms displaced by N(0, sigma) per axis; RMS offset [m].

    Corridors stay where the plan has them: they abut one another, and moving two abutting
    floors apart would leave a sliver of wall across the junction that no building has.
    """
    moved = plan
    rooms: list[Room] = []
    offsets: list[float] = []
    for room in plan.rooms:
        dx, dy = (float(v) for v in rng.normal(0.0, sigma, 2))
        furniture = tuple(_shifted(f, dx, dy) for f in room.furniture)
        shifted = msgspec.structs.replace(_shifted(room, dx, dy), furniture=furniture)
        if not _opens(moved, shifted):  # a door no longer reaches its corridor: keep the room
            shifted, dx, dy = room, 0.0, 0.0
        rooms.append(shifted)
        offsets.append(math.hypot(dx, dy))
    rms = float(np.sqrt(np.mean(np.square(offsets)))) if offsets else 0.0
    return msgspec.structs.replace(moved, rooms=tuple(rooms)), rms


def _close_doors(plan: FloorPlan, rng: np.random.Generator, n: int, notes: list[str]) -> FloorPlan:
    # Doors that stay open: of rooms with a node inside them, and of home.
    protected = {r.name for r in plan.rooms if r.inside is not None or r.home}
    candidates = [i for i, r in enumerate(plan.rooms) if r.doors and r.name not in protected]
    rooms = list(plan.rooms)
    for i in rng.permutation(candidates)[:n]:
        room = rooms[int(i)]
        rooms[int(i)] = msgspec.structs.replace(room, doors=room.doors[1:])
        notes.append(f"door of {room.name!r} closed (open in the map)")
    return msgspec.structs.replace(plan, rooms=tuple(rooms))


def _open_doors(plan: FloorPlan, rng: np.random.Generator, n: int, notes: list[str]) -> FloorPlan:
    rooms = list(plan.rooms)
    opened = 0
    for i in rng.permutation(len(rooms)):
        if opened >= n:
            break
        room = rooms[int(i)]
        for trial, _ in _wall_openings(plan, room, rng, 0.9, 2.0):
            zone = door_approach_zone(trial, len(trial.doors) - 1)
            if any(f.rect.overlaps(zone) for f in room.furniture):
                continue
            rooms[int(i)] = trial
            notes.append(f"extra door into {room.name!r} (a wall in the map)")
            opened += 1
            break
    return msgspec.structs.replace(plan, rooms=tuple(rooms))


def _move_tables(plan: FloorPlan, rng: np.random.Generator, n: int, notes: list[str]) -> FloorPlan:
    rooms = list(plan.rooms)
    moved = 0
    for i in rng.permutation(len(rooms)):
        room = rooms[int(i)]
        if moved >= n or not room.furniture:
            continue
        zones = [door_approach_zone(room, k) for k in range(len(room.doors))]
        inner = Rect(room.rect.x0 + 0.1, room.rect.y0 + 0.1, room.rect.x1 - 0.1, room.rect.y1 - 0.1)
        k = int(rng.integers(len(room.furniture)))
        item = room.furniture[k]
        for _ in range(20):
            angle = rng.uniform(-math.pi, math.pi)
            dist = rng.uniform(0.3, 0.6)
            moved_item = _shifted(item, dist * math.cos(angle), dist * math.sin(angle))
            rect = moved_item.rect
            others = [f.rect for j, f in enumerate(room.furniture) if j != k]
            inside = inner.contains(rect) and not any(rect.overlaps(z) for z in zones)
            if inside and not any(rect.overlaps(o, 0.3) for o in others):
                furniture = list(room.furniture)
                furniture[k] = moved_item
                rooms[int(i)] = msgspec.structs.replace(room, furniture=tuple(furniture))
                notes.append(f"{item.name!r} in {room.name!r} moved {dist:.2f} m")
                moved += 1
                break
    return msgspec.structs.replace(plan, rooms=tuple(rooms))


def _wall_openings(
    plan: FloorPlan, room: Room, rng: np.random.Generator, width: float, spacing: float
) -> Iterator[tuple[Room, Rect]]:
    """``room`` with one more door of ``width`` [m] in the wall of its first door, at least
    ``spacing`` [m] from it, and that door's opening: tried at 8 random offsets, yielding those
    that reach a corridor (none for a room without doors)."""
    if not room.doors:
        return
    first = room.doors[0]
    length = room.rect.width if first.wall in ("north", "south") else room.rect.height
    for offset in rng.uniform(0.8, max(length - 0.8, 0.81), 8):
        if abs(offset - first.offset) < spacing:
            continue
        trial = msgspec.structs.replace(
            room, doors=(*room.doors, Door(first.wall, float(offset), width))
        )
        try:
            opening = door_opening(plan, trial, len(trial.doors) - 1)
        except FloorPlanError:
            continue
        yield trial, opening


def _glass_panels(
    plan: FloorPlan, rng: np.random.Generator, n: int, notes: list[str]
) -> list[Rect]:
    """Wall sections (1.2 m, the width a door could have) between a room and its corridor."""
    panels: list[Rect] = []
    for i in rng.permutation(len(plan.rooms)):
        if len(panels) >= n:
            break
        room = plan.rooms[int(i)]
        for _, rect in _wall_openings(plan, room, rng, 1.2, 1.8):
            panels.append(rect)
            notes.append(f"glass in the {room.doors[0].wall} wall of {room.name!r}")
            break
    return panels


def world_from_plan(
    plan: FloorPlan, rng: np.random.Generator, variation: WorldVariation
) -> tuple[OccupancyGrid, list[Rect], list[str]]:
    """The plan drawn again at ``variation.resolution``, displaced, doors and tables changed."""
    notes: list[str] = []
    displaced, rms = _displace_plan(plan, rng, variation.wall_sigma)
    redrawn = f"floor plan redrawn at {variation.resolution * 100:.0f} cm"
    notes.append(f"{redrawn}, rooms offset {rms * 100:.1f} cm RMS")
    changed = _close_doors(displaced, rng, variation.doors_closed, notes)
    changed = _open_doors(changed, rng, variation.doors_opened, notes)
    changed = _move_tables(changed, rng, variation.tables_moved, notes)
    glass = _glass_panels(changed, rng, variation.glass_panels, notes)
    fine = msgspec.structs.replace(
        changed, map=msgspec.structs.replace(changed.map, resolution=variation.resolution)
    )
    grid = rasterise(fine)
    cells = grid.cells.copy()
    for pane in glass:  # the wall section becomes floor; the pane itself is drawn as glass
        r0, c0 = grid.world_to_cell(pane.x0 + 1e-6, pane.y0 + 1e-6)
        r1, c1 = grid.world_to_cell(pane.x1 - 1e-6, pane.y1 - 1e-6)
        cells[int(r0) : int(r1) + 1, int(c0) : int(c1) + 1] = FREE
    return grid.with_cells(cells), glass, notes


# ---------------------------------------------------------------------------- occupancy grids


def warped_grid(
    grid: OccupancyGrid, rng: np.random.Generator, variation: WorldVariation
) -> tuple[OccupancyGrid, float]:
    """``grid`` upsampled to ``variation.resolution`` and warped; RMS displacement [m]."""
    factor = max(1, round(grid.resolution / variation.resolution))
    res = grid.resolution / factor
    codes = np.zeros(grid.cells.shape, dtype=np.uint8)
    codes[grid.cells == OCCUPIED] = 1
    codes[grid.cells == UNKNOWN] = 2
    up = np.repeat(np.repeat(codes, factor, axis=0), factor, axis=1)
    rows, cols = up.shape
    w_m, h_m = cols * res, rows * res
    lattice = (
        max(2, math.ceil(h_m / variation.warp_length) + 1),
        max(2, math.ceil(w_m / variation.warp_length) + 1),
    )
    dx = rng.normal(0.0, variation.wall_sigma, lattice).astype(np.float32)
    dy = rng.normal(0.0, variation.wall_sigma, lattice).astype(np.float32)
    dx_full = cv2.resize(dx, (cols, rows), interpolation=cv2.INTER_CUBIC)
    dy_full = cv2.resize(dy, (cols, rows), interpolation=cv2.INTER_CUBIC)
    col_idx, row_idx = np.meshgrid(
        np.arange(cols, dtype=np.float32), np.arange(rows, dtype=np.float32)
    )
    # The world at p shows what the map has at p - d: walls move by +d.
    map_x = np.asarray(col_idx - dx_full / res, dtype=np.float32)
    map_y = np.asarray(row_idx - dy_full / res, dtype=np.float32)
    warped = cv2.remap(up, map_x, map_y, cv2.INTER_NEAREST, borderValue=2)
    cells = np.full(warped.shape, FREE, dtype=np.int8)
    cells[warped == 1] = OCCUPIED
    cells[warped == 2] = UNKNOWN
    rms = float(np.sqrt(np.mean(dx_full**2 + dy_full**2)))
    out = OccupancyGrid(
        cells, res, grid.origin_x, grid.origin_y, source=f"{grid.source} (simulated building)"
    )
    return out, rms


# ---------------------------------------------------------------------------- clutter


def _segment_distance(px: FloatArray, py: FloatArray, segs: FloatArray) -> FloatArray:
    """Distance from each point to the nearest of the segments (rows x0, y0, x1, y1)."""
    if segs.size == 0:
        return np.full(px.shape, np.inf)
    ax, ay, bx, by = (segs[:, k][None, :] for k in range(4))
    dx, dy = bx - ax, by - ay
    length2 = np.maximum(dx * dx + dy * dy, 1e-12)
    t = np.clip(((px[:, None] - ax) * dx + (py[:, None] - ay) * dy) / length2, 0.0, 1.0)
    d = np.hypot(px[:, None] - ax - t * dx, py[:, None] - ay - t * dy)
    result: FloatArray = d.min(axis=1)
    return result


def _rect_points(item: Item, spacing: float = 0.05) -> FloatArray:
    nx = max(2, math.ceil(item.size_x / spacing) + 1)
    ny = max(2, math.ceil(item.size_y / spacing) + 1)
    u, v = np.meshgrid(
        np.linspace(-item.size_x / 2, item.size_x / 2, nx),
        np.linspace(-item.size_y / 2, item.size_y / 2, ny),
    )
    c, s = math.cos(item.yaw), math.sin(item.yaw)
    x = item.center_x + c * u.ravel() - s * v.ravel()
    y = item.center_y + s * u.ravel() + c * v.ravel()
    return np.column_stack((x, y))


def _chair(x: float, y: float, yaw: float) -> list[Item]:
    half = CHAIR_SIDE / 2
    c, s = math.cos(yaw), math.sin(yaw)
    legs = []
    for u, v in ((-half, -half), (half, -half), (half, half), (-half, half)):
        legs.append(Item("chair-leg", x + c * u - s * v, y + s * u + c * v, CHAIR_LEG, CHAIR_LEG))
    return legs


class _Placer:
    """Random free spots for clutter, away from the graph, the start and each other."""

    def __init__(
        self,
        grid: OccupancyGrid,
        clearance_m: FloatArray,
        topo: TopologicalMap | None,
        keep_clear: Sequence[tuple[float, float]],
        variation: WorldVariation,
        rng: np.random.Generator,
    ) -> None:
        self.grid = grid
        self.clearance = clearance_m
        self.rng = rng
        self.variation = variation
        nodes = [(n.pose.x, n.pose.y) for n in topo.nodes] if topo is not None else []
        self.nodes = np.array(nodes + list(keep_clear), dtype=np.float64).reshape(-1, 2)
        segs = []
        if topo is not None:
            for u, v, _ in topo.weighted_arcs():
                a, b = topo.node(u).pose, topo.node(v).pose
                segs.append((a.x, a.y, b.x, b.y))
        self.segments = np.array(segs, dtype=np.float64).reshape(-1, 4)
        self.placed: list[FloatArray] = []
        free = np.argwhere(clearance_m > 0.2)
        self.free = free
        xs, ys = grid.cell_to_world(free[:, 0], free[:, 1])
        self.free_xy = np.column_stack((np.asarray(xs), np.asarray(ys)))
        self.arc_distance = self._arc_distance_field()[free[:, 0], free[:, 1]]

    def _arc_distance_field(self) -> FloatArray:
        """Distance [m] from each cell to the nearest arc (arcs drawn as 1-cell lines)."""
        g = self.grid
        lines = np.ones((g.height, g.width), dtype=np.uint8)
        for x0, y0, x1, y1 in self.segments:
            r0, c0 = g.world_to_cell(x0, y0)
            r1, c1 = g.world_to_cell(x1, y1)
            cv2.line(lines, (int(c0), int(r0)), (int(c1), int(r1)), 0, 1)
        if self.segments.size == 0:
            return np.full(lines.shape, np.inf)
        d = cv2.distanceTransform(lines, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        return np.asarray(d, dtype=np.float64) * g.resolution

    def _ok(self, item_pts: FloatArray, margin_to_others: float = 0.4) -> bool:
        v = self.variation
        rows, cols = self.grid.world_to_cell(item_pts[:, 0], item_pts[:, 1])
        inside = self.grid.in_bounds(rows, cols)
        if not bool(inside.all()):
            return False
        if bool((self.clearance[rows, cols] <= 0.0).any()):
            return False  # overlaps a wall: an item stands on the floor
        if self.segments.size:
            to_arcs = _segment_distance(item_pts[:, 0], item_pts[:, 1], self.segments)
            if bool((to_arcs < v.route_clearance).any()):
                return False
        if self.nodes.size:
            d = np.hypot(
                item_pts[:, 0, None] - self.nodes[None, :, 0],
                item_pts[:, 1, None] - self.nodes[None, :, 1],
            )
            if bool((d < v.node_clearance).any()):
                return False
        for other in self.placed:
            d = np.hypot(
                item_pts[:, 0, None] - other[None, :, 0], item_pts[:, 1, None] - other[None, :, 1]
            )
            if bool((d < margin_to_others).any()):
                return False
        return True

    def place(self, kind: str) -> list[Item]:
        """One item of ``kind`` (box, chair, corridor box), or none if no spot was found."""
        rng = self.rng
        if kind == "corridor box":
            # Against a wall (clearance small) within 1.6 m of an arc: in a corridor.
            pool = np.flatnonzero(
                (self.arc_distance < 1.6) & (self.clearance[self.free[:, 0], self.free[:, 1]] < 0.4)
            )
        else:
            pool = np.flatnonzero(self.arc_distance > 1.2)
        if pool.size == 0:
            return []
        for _ in range(_PLACEMENT_TRIES):
            x, y = self.free_xy[int(pool[rng.integers(pool.size)])]
            yaw = float(rng.uniform(-math.pi, math.pi))
            if kind == "chair":
                items = _chair(float(x), float(y), yaw)
                pts = np.concatenate([_rect_points(i, 0.02) for i in items])
            else:
                sx, sy = (float(s) for s in rng.uniform(0.3, 0.6, 2))
                if kind == "corridor box":
                    sx, sy = sx, min(sy, 0.45)
                items = [Item(kind, float(x), float(y), sx, sy, yaw)]
                pts = _rect_points(items[0])
            if self._ok(pts):
                self.placed.append(pts)
                return items
        return []


def place_clutter(
    grid: OccupancyGrid,
    topo: TopologicalMap | None,
    rng: np.random.Generator,
    variation: WorldVariation,
    keep_clear: Sequence[tuple[float, float]] = (),
) -> list[Item]:
    """Boxes, chairs and corridor boxes on free floor of ``grid`` (see the module docstring)."""
    coarse = max(1, round(0.05 / grid.resolution))
    blocked = grid.blocked()[::coarse, ::coarse]
    view = OccupancyGrid(
        np.where(blocked, OCCUPIED, FREE).astype(np.int8),
        grid.resolution * coarse,
        grid.origin_x,
        grid.origin_y,
        source=grid.source,
    )
    free = np.ascontiguousarray(~blocked, dtype=np.uint8)
    clearance = (
        np.asarray(cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE), np.float64)
        * view.resolution
    )
    placer = _Placer(view, clearance, topo, keep_clear, variation, rng)
    items: list[Item] = []
    for kind, count in (
        ("corridor box", variation.corridor_items),
        ("box", variation.boxes),
        ("chair", variation.chairs),
    ):
        for _ in range(count):
            items.extend(placer.place(kind))
    return items


# ---------------------------------------------------------------------------- entry point


def build_sim_world(
    map_grid: OccupancyGrid,
    rng: np.random.Generator,
    *,
    plan_yaml: Path | None = None,
    topo: TopologicalMap | None = None,
    keep_clear: Sequence[tuple[float, float]] = (),
    variation: WorldVariation | None = None,
) -> SimWorldSpec:
    """The simulator's building for ``map_grid``: from its floor plan if given, else the grid."""
    v = variation or WorldVariation()
    if plan_yaml is not None:
        plan = load_floor_plan(plan_yaml)
        grid, glass, notes = world_from_plan(plan, rng, v)
    else:
        grid, rms = warped_grid(map_grid, rng, v)
        glass = []
        notes = [
            f"map redrawn at {grid.resolution * 100:.1f} cm and warped "
            f"{rms * 100:.1f} cm RMS (lattice {v.warp_length:g} m)"
        ]
    items = place_clutter(grid, topo, rng, v, keep_clear)
    n_chairs = sum(1 for i in items if i.kind == "chair-leg") // 4
    n_corr = sum(1 for i in items if i.kind == "corridor box")
    n_box = sum(1 for i in items if i.kind == "box")
    notes.append(
        f"clutter not in the map: {n_box} boxes, {n_chairs} chairs, {n_corr} boxes in corridors"
    )
    spec = SimWorldSpec(grid, tuple(glass), tuple(items), tuple(notes))
    logger.info("simulated building for %s: %s", map_grid.source, spec.describe())
    return spec
