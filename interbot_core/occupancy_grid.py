"""Occupancy grids in the ROS map_server format (YAML + PGM/PNG image).

The YAML keys are those of map_server (ROS wiki, `map_server`): ``image``, ``resolution`` [m/cell],
``origin`` [x, y, yaw] (pose of the lower-left pixel in the ``map`` frame), ``negate``,
``occupied_thresh``, ``free_thresh`` and optional ``mode`` (only ``trinary``, the default, is
supported). As in map_server, a pixel's occupancy probability is ``p = (255 - v) / 255`` (or
``v / 255`` with ``negate: 1``); ``p > occupied_thresh`` is occupied, ``p < free_thresh`` free and
anything between unknown.

In memory the grid is row-major with row 0 at the *bottom* (lowest y), the layout of
nav_msgs/OccupancyGrid, so ``cells[row, col]`` is at ``(origin_x + (col + 0.5) * res,
origin_y + (row + 0.5) * res)``. PGM images store the top row first, so loading flips them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import msgspec
import numpy as np
import numpy.typing as npt
import yaml
from msgspec import Meta

from interbot_core import schema

# Cell values, as in nav_msgs/OccupancyGrid.
FREE = 0
OCCUPIED = 100
UNKNOWN = -1


class MapLoadError(ValueError):
    """A map file is missing, malformed or inconsistent; the message names the file."""


@dataclass(frozen=True)
class OccupancyGrid:
    """A static occupancy grid: ``cells`` int8 (FREE, OCCUPIED, UNKNOWN), row 0 at the bottom."""

    cells: npt.NDArray[np.int8]
    resolution: float  # [m/cell]
    origin_x: float  # [m] map-frame x of the lower-left corner of cell (0, 0)
    origin_y: float  # [m]
    origin_yaw: float = 0.0  # [rad] only 0 is supported for geometry helpers
    source: str = "<memory>"
    _occupied_mask: npt.NDArray[np.bool_] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.cells.ndim != 2 or self.cells.size == 0:
            raise MapLoadError(f"{self.source}: grid must be a non-empty 2-D array")
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise MapLoadError(f"{self.source}: resolution must be > 0, got {self.resolution}")
        if not (math.isfinite(self.origin_x) and math.isfinite(self.origin_y)):
            raise MapLoadError(f"{self.source}: origin must be finite")
        cells = np.ascontiguousarray(self.cells, dtype=np.int8)
        cells.setflags(write=False)
        object.__setattr__(self, "cells", cells)
        mask = cells == OCCUPIED
        mask.setflags(write=False)
        object.__setattr__(self, "_occupied_mask", mask)

    @property
    def height(self) -> int:
        """Number of rows (cells along y)."""
        return int(self.cells.shape[0])

    @property
    def width(self) -> int:
        """Number of columns (cells along x)."""
        return int(self.cells.shape[1])

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the grid [m]."""
        return self.width * self.resolution, self.height * self.resolution

    def occupied(self) -> npt.NDArray[np.bool_]:
        """Boolean mask of occupied cells."""
        return self._occupied_mask

    def blocked(self) -> npt.NDArray[np.bool_]:
        """Occupied or unknown: what a simulator treats as wall."""
        blocked: npt.NDArray[np.bool_] = self.cells != FREE
        return blocked

    def world_to_cell(
        self, x: npt.ArrayLike, y: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Map-frame points [m] to (row, col) indices (may lie outside the grid)."""
        col = np.floor((np.asarray(x, dtype=float) - self.origin_x) / self.resolution)
        row = np.floor((np.asarray(y, dtype=float) - self.origin_y) / self.resolution)
        return row.astype(np.int64), col.astype(np.int64)

    def cell_to_world(
        self, row: npt.ArrayLike, col: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(row, col) indices to the map-frame centre of the cell [m]."""
        x = self.origin_x + (np.asarray(col, dtype=float) + 0.5) * self.resolution
        y = self.origin_y + (np.asarray(row, dtype=float) + 0.5) * self.resolution
        return x, y

    def in_bounds(self, row: npt.ArrayLike, col: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True where (row, col) is inside the grid."""
        r, c = np.asarray(row), np.asarray(col)
        return (r >= 0) & (r < self.height) & (c >= 0) & (c < self.width)

    def is_free(self, x: float, y: float) -> bool:
        """True if the map-frame point lies in a known free cell."""
        row, col = self.world_to_cell(x, y)
        if not bool(self.in_bounds(row, col)):
            return False
        return bool(self.cells[int(row), int(col)] == FREE)

    def with_cells(self, cells: npt.NDArray[np.int8]) -> OccupancyGrid:
        """A copy of this grid's geometry with other cell values."""
        return OccupancyGrid(
            cells, self.resolution, self.origin_x, self.origin_y, self.origin_yaw, self.source
        )

    def save(self, yaml_path: str | Path, image_name: str | None = None) -> Path:
        """Write map_server YAML + binary PGM (0 occupied, 254 free, 205 unknown)."""
        yaml_path = Path(yaml_path)
        image_name = image_name or yaml_path.with_suffix(".pgm").name
        image = np.full(self.cells.shape, 205, dtype=np.uint8)
        image[self.cells == FREE] = 254
        image[self.cells == OCCUPIED] = 0
        write_pgm(yaml_path.parent / image_name, image[::-1])
        meta = {
            "image": image_name,
            "resolution": float(self.resolution),
            "origin": [float(self.origin_x), float(self.origin_y), float(self.origin_yaw)],
            "negate": 0,
            "occupied_thresh": 0.65,
            "free_thresh": 0.196,
        }
        yaml_path.write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
        return yaml_path


def read_pgm(path: str | Path) -> npt.NDArray[np.uint8]:
    """Read a binary (P5) or ASCII (P2) PGM with maxval <= 255; top row first."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MapLoadError(f"{path}: cannot read map image ({exc.strerror})") from exc
    tokens: list[bytes] = []
    pos = 0
    # Header: magic, width, height, maxval; '#' comments run to end of line.
    while len(tokens) < 4:
        while pos < len(data) and data[pos : pos + 1].isspace():
            pos += 1
        if pos >= len(data):
            raise MapLoadError(f"{path}: truncated PGM header")
        if data[pos : pos + 1] == b"#":
            end = data.find(b"\n", pos)
            pos = len(data) if end < 0 else end + 1
            continue
        start = pos
        while pos < len(data) and not data[pos : pos + 1].isspace():
            pos += 1
        tokens.append(data[start:pos])
    magic = tokens[0]
    try:
        width, height, maxval = (int(t) for t in tokens[1:4])
    except ValueError as exc:
        raise MapLoadError(f"{path}: malformed PGM header {tokens!r}") from exc
    if magic not in (b"P5", b"P2") or width <= 0 or height <= 0 or not 0 < maxval <= 255:
        raise MapLoadError(f"{path}: only 8-bit P5/P2 PGM images are supported")
    if magic == b"P5":
        body = data[pos + 1 :]
        if len(body) != width * height:
            raise MapLoadError(
                f"{path}: image data is {len(body)} bytes but the header says "
                f"{width}x{height} = {width * height}"
            )
        pixels = np.frombuffer(body, dtype=np.uint8)
    else:
        values = data[pos:].split()
        if len(values) != width * height:
            raise MapLoadError(
                f"{path}: image has {len(values)} values but the header says "
                f"{width}x{height} = {width * height}"
            )
        pixels = np.array(values, dtype=np.uint8)
    image = pixels.reshape(height, width)
    if maxval != 255:
        image = (image.astype(np.uint16) * 255 // maxval).astype(np.uint8)
    return image


def write_pgm(path: str | Path, image: npt.NDArray[np.uint8]) -> None:
    """Write a binary P5 PGM, top row first."""
    image = np.ascontiguousarray(image, dtype=np.uint8)
    header = f"P5\n{image.shape[1]} {image.shape[0]}\n255\n".encode("ascii")
    Path(path).write_bytes(header + image.tobytes())


class MapServerYaml(msgspec.Struct, frozen=True):
    """The keys of a ROS map_server YAML file that this loader reads (others are ignored, as
    map_server ignores them); ``mode`` must be ``trinary``, the only mode read here."""

    image: Annotated[str, Meta(min_length=1)]
    resolution: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "m"})]
    origin: tuple[schema.Finite, schema.Finite, schema.Finite]
    negate: bool | Annotated[int, Meta(ge=0, le=1)] = 0
    occupied_thresh: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.65
    free_thresh: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.196
    mode: Literal["trinary"] = "trinary"


def load_map(yaml_path: str | Path) -> OccupancyGrid:
    """Load a map_server YAML file and its image into an `OccupancyGrid`."""
    yaml_path = Path(yaml_path)
    raw = schema.read_yaml(yaml_path, MapLoadError, "map file")
    meta = schema.load(raw, MapServerYaml, "", str(yaml_path), MapLoadError)
    occ_t, free_t, origin = meta.occupied_thresh, meta.free_thresh, meta.origin
    if not free_t < occ_t:
        raise MapLoadError(f"{yaml_path}: need 0 <= free_thresh < occupied_thresh <= 1")
    image_name, resolution, negate = meta.image, meta.resolution, meta.negate
    image_path = (yaml_path.parent / image_name).resolve()
    image = read_pgm(image_path)
    if negate:
        p_occupied = image.astype(np.float64) / 255.0
    else:
        p_occupied = (255.0 - image.astype(np.float64)) / 255.0
    cells = np.full(image.shape, UNKNOWN, dtype=np.int8)
    cells[p_occupied > occ_t] = OCCUPIED
    cells[p_occupied < free_t] = FREE
    return OccupancyGrid(
        cells[::-1].copy(),
        float(resolution),
        float(origin[0]),
        float(origin[1]),
        float(origin[2]),
        str(yaml_path),
    )
