"""How wide is the floor along each arc of a topological graph? (issue 12 point 2)

For every arc the report gives two widths [m], free wall face to free wall face:

- *straight*: the narrowest gap the arc's straight segment crosses (``2 d - res`` at its worst
  sample, ``d`` the distance from a cell centre to the nearest occupied or unknown cell centre:
  a corridor of ``n`` free cells has ``d = (n + 1) res / 2`` at its middle);
- *widest*: the widest passage that joins the two nodes within ``--band`` metres of the segment
  (a bottleneck, or maximin, path: the largest width ``w`` such that the cells with
  ``2 d - res >= w`` connect both ends), and where its narrowest point lies
  (`robot_daemon.planning.bottleneck`).

An arc whose *widest* is below the robot's width plus a margin cannot be driven whatever the
planner does; one whose *straight* alone is low only needs the planner to leave the segment.

    python tools/topo_gaps.py --map ../shared/data/maps/willow.yaml --topo maps/willow_topo.yaml
    python tools/topo_gaps.py ... --below 0.9     # only arcs narrower than 0.9 m
    python tools/topo_gaps.py ... --json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.topological_map import TopologicalMap, load_topological_map
from robot_daemon.planning import bottleneck


@dataclass(frozen=True)
class ArcGap:
    """The free width along one arc [m] and the place of its narrowest point."""

    a: int
    b: int
    length_m: float
    straight_m: float  # narrowest gap on the straight segment
    straight_at: tuple[float, float]
    widest_m: float  # widest passage joining a and b within the band
    widest_at: tuple[float, float]  # where that passage is narrowest


def free_width(grid: OccupancyGrid) -> npt.NDArray[np.float64]:
    """Per cell, the width [m] of the gap it sits in (see robot_daemon.planning.bottleneck)."""
    distance = ndimage.distance_transform_edt(~grid.blocked(), sampling=grid.resolution)
    return bottleneck.free_width(distance, grid.resolution)


def _segment_cells(
    grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    n = max(2, math.ceil(math.dist(a, b) / (0.25 * grid.resolution)) + 1)
    t = np.linspace(0.0, 1.0, n)
    xs = a[0] + (b[0] - a[0]) * t
    ys = a[1] + (b[1] - a[1]) * t
    rows, cols = grid.world_to_cell(xs, ys)
    return np.asarray(rows), np.asarray(cols), np.column_stack((xs, ys))


def _band_mask(
    grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float], band: float
) -> tuple[npt.NDArray[np.bool_], tuple[int, int]]:
    """Cells within ``band`` metres of the segment, as a window of the grid and its offset."""
    rows, cols = grid.world_to_cell(
        [min(a[0], b[0]) - band, max(a[0], b[0]) + band],
        [min(a[1], b[1]) - band, max(a[1], b[1]) + band],
    )
    r0, r1 = max(int(rows[0]), 0), min(int(rows[1]) + 1, grid.height)
    c0, c1 = max(int(cols[0]), 0), min(int(cols[1]) + 1, grid.width)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    x = grid.origin_x + (cc + 0.5) * grid.resolution
    y = grid.origin_y + (rr + 0.5) * grid.resolution
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    t = np.clip(((x - ax) * dx + (y - ay) * dy) / length2, 0.0, 1.0) if length2 > 0 else 0.0
    mask = np.hypot(x - (ax + t * dx), y - (ay + t * dy)) <= band
    return mask, (r0, c0)


def widest_passage(
    width: npt.NDArray[np.float64],
    grid: OccupancyGrid,
    a: tuple[float, float],
    b: tuple[float, float],
    band: float,
) -> tuple[float, tuple[float, float]]:
    """The bottleneck width [m] between ``a`` and ``b`` within the band, and where it lies."""
    mask, (r0, c0) = _band_mask(grid, a, b, band)
    h, w = mask.shape
    local = np.where(mask, width[r0 : r0 + h, c0 : c0 + w], 0.0)
    (ra, rb), (ca, cb) = grid.world_to_cell([a[0], b[0]], [a[1], b[1]])
    found = bottleneck.widest_way(local, (int(ra) - r0, int(ca) - c0), (int(rb) - r0, int(cb) - c0))
    x = grid.origin_x + (found.col + c0 + 0.5) * grid.resolution
    y = grid.origin_y + (found.row + r0 + 0.5) * grid.resolution
    return found.width, (round(float(x), 2), round(float(y), 2))


def arc_gaps(grid: OccupancyGrid, topo: TopologicalMap, band: float = 1.5) -> list[ArcGap]:
    """Widths along every arc of ``topo`` on ``grid`` (see the module docstring)."""
    width = free_width(grid)
    result = []
    for arc in topo.arcs:
        na, nb = topo.node(arc.u), topo.node(arc.v)
        a, b = (na.pose.x, na.pose.y), (nb.pose.x, nb.pose.y)
        rows, cols, xy = _segment_cells(grid, a, b)
        inside = grid.in_bounds(rows, cols)
        along = np.zeros(len(rows))
        along[inside] = width[rows[inside], cols[inside]]
        k = int(np.argmin(along))
        widest, at = widest_passage(width, grid, a, b, band)
        result.append(
            ArcGap(
                arc.u,
                arc.v,
                round(math.dist(a, b), 2),
                round(float(along[k]), 3),
                (round(float(xy[k, 0]), 2), round(float(xy[k, 1]), 2)),
                round(widest, 3),
                at,
            )
        )
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map", type=Path, required=True, help="map_server YAML")
    parser.add_argument("--topo", type=Path, required=True, help="topological map YAML")
    parser.add_argument("--band", type=float, default=1.5, help="[m] search band for 'widest'")
    parser.add_argument("--below", type=float, default=math.inf, help="[m] only narrower arcs")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    grid = load_map(args.map)
    topo = load_topological_map(args.topo)
    gaps = [
        g for g in arc_gaps(grid, topo, args.band) if min(g.straight_m, g.widest_m) < args.below
    ]
    if args.json:
        print(json.dumps([asdict(g) for g in gaps]))
        return 0
    print(f"{'arc':>9} {'len m':>6} {'straight m':>10} {'at':>14} {'widest m':>9} {'at':>14}")
    for g in gaps:
        print(
            f"{g.a:>4}-{g.b:<4} {g.length_m:6.2f} {g.straight_m:10.2f} "
            f"{g.straight_at!s:>14} {g.widest_m:9.2f} {g.widest_at!s:>14}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
