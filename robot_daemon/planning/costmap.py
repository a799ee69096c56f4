"""A 2-D navigation costmap: the a-priori map plus live laser obstacles, inflated as in Nav2.

The global costmap of the Hybrid Motion Planner (thesis §3.3.1): obstacles of the a-priori metric
map (occupied *and* unknown cells are lethal; with ``allow_unknown``, as Nav2's planners by
default, unknown cells are traversable at the highest non-lethal cost) and obstacles the laser sees within
``obstacle_max_range`` are inflated "to mark all the areas where the robot's position is not
valid". Live obstacles are marked for ``obstacle_persistence`` seconds and cleared earlier when a
later beam passes through their cell (ray tracing free space), as Nav2's obstacle layer does:
every cell-sized step along the beams, one compiled loop (`clear_live_cells`, `robot_daemon.jit`).

Inflation follows Nav2's ``InflationLayer`` (navigation2/nav2_costmap_2d/inflation_layer.hpp)::

    d = 0                               -> LETHAL_OBSTACLE   = 254
    0 < d <= r_inscribed                -> INSCRIBED         = 253
    r_inscribed < d <= r_inflation      -> floor(252 * exp(-k * (d - r_inscribed)))
    d > r_inflation                     -> FREE_SPACE        = 0

with ``d`` the Euclidean distance [m] from a cell centre to the nearest obstacle cell centre
(``scipy.ndimage.distance_transform_edt``), ``r_inscribed`` half the robot width and ``k`` the
cost scaling factor. A robot centre in a cell of cost >= 253 certainly collides.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon import jit
from robot_daemon.planning.config import PlannerConfig

CLEARING_BEAM_SPACING = math.radians(0.5)  # [rad] clearing uses beams at least this far apart
_WINDOW_MARGIN = 1e-6  # [rad] beyond a cell's exact angular extent, far above rounding

FloatArray = npt.NDArray[np.float64]

LETHAL = 254
INSCRIBED = 253
MAX_NON_LETHAL = 252
FREE_COST = 0
UNKNOWN_COST = MAX_NON_LETHAL  # allow_unknown: the dearest traversable cell


def inflation_cost(
    distance: npt.ArrayLike,
    inscribed_radius: float,
    inflation_radius: float,
    cost_scaling_factor: float,
) -> npt.NDArray[np.uint8]:
    """Nav2's cost of a cell at ``distance`` [m] from the nearest obstacle.

    ``cost = 252 * exp(-k * (d - r_inscribed))`` for ``r_inscribed < d <= r_inflation``,
    253 inside the inscribed radius, 254 on the obstacle (d == 0) and 0 beyond the inflation
    radius. The value is truncated to an integer, as Nav2's ``unsigned char`` cast does.
    """
    d = np.asarray(distance, dtype=np.float64)
    factor = np.exp(-cost_scaling_factor * np.maximum(d - inscribed_radius, 0.0))
    cost = np.floor(MAX_NON_LETHAL * factor)
    cost = np.where(d > inflation_radius, FREE_COST, cost)
    cost = np.where(d <= inscribed_radius, INSCRIBED, cost)
    cost = np.where(d <= 0.0, LETHAL, cost)
    return cost.astype(np.uint8)


@jit.kernel
def clear_live_cells(
    marked_until: FloatArray,
    origin_x: float,
    origin_y: float,
    resolution: float,
    x: float,
    y: float,
    cos_b: FloatArray,
    sin_b: FloatArray,
    t: FloatArray,
    reach: FloatArray,
    now: float,
) -> None:
    """Ray tracing of free space: along beam ``b`` from (x, y) at the samples
    ``p_k = (x + cos_b * t_k, y + sin_b * t_k)`` with ``t_k < reach[b]`` (``t`` ascending, the
    same ``t`` for every beam), a cell holding a sample loses its live mark (expiry > ``now``).

    The cell of a sample is ``(floor((p_y - origin_y) / resolution), floor((p_x - origin_x) /
    resolution))``, as `OccupancyGrid.world_to_cell` computes it; samples off the grid clear
    nothing. A scan's ~25 000 samples as one loop, where numpy needed a dozen array passes.
    """
    height, width = marked_until.shape
    for b in range(reach.size):
        c, s, r = cos_b[b], sin_b[b], reach[b]
        for k in range(t.size):
            tk = t[k]
            if not tk < r:
                break
            col = math.floor((x + c * tk - origin_x) / resolution)
            row = math.floor((y + s * tk - origin_y) / resolution)
            if 0 <= row < height and 0 <= col < width and marked_until[row, col] > now:
                marked_until[row, col] = -math.inf


@jit.kernel
def mark_endpoints(
    marked_until: FloatArray,
    valid: npt.NDArray[np.bool_],
    ranges: FloatArray,
    cos: FloatArray,
    sin: FloatArray,
    max_range: float,
    x: float,
    y: float,
    c: float,
    s: float,
    origin_x: float,
    origin_y: float,
    resolution: float,
    until: float,
) -> tuple[int, int, int, int]:
    """Mark the cells where the valid beams within ``max_range`` end as live until ``until``
    (or later, where a cell is marked longer); returns the (row, row, col, col) extremes of the
    marked cells, all -1 when none.

    Beam ``b`` of a sensor at (x, y) with heading (c, s) = (cos, sin) ends at ``(x + c * p_x -
    s * p_y, y + s * p_x + c * p_y)``, ``p = ranges[b] * (cos[b], sin[b])``, in the cell of
    `OccupancyGrid.world_to_cell`; ends off the grid mark nothing.
    """
    height, width = marked_until.shape
    row0 = row1 = col0 = col1 = -1
    for b in range(ranges.size):
        if not (valid[b] and ranges[b] <= max_range):
            continue
        px, py = ranges[b] * cos[b], ranges[b] * sin[b]
        col = math.floor((x + c * px - s * py - origin_x) / resolution)
        row = math.floor((y + s * px + c * py - origin_y) / resolution)
        if not (0 <= row < height and 0 <= col < width):
            continue
        marked_until[row, col] = max(marked_until[row, col], until)
        if row0 < 0:
            row0 = row1 = row
            col0 = col1 = col
        else:
            row0, row1 = min(row0, row), max(row1, row)
            col0, col1 = min(col0, col), max(col1, col)
    return row0, row1, col0, col1


class Costmap:
    """Static map layer + laser obstacle layer + inflation, on the map's own grid.

    ``update(now, pose, scan)`` marks and clears live obstacles; ``costs(now)`` returns the
    inflated uint8 cost grid (row 0 at the bottom, the geometry of ``grid``). Expired marks are
    ignored at read time, so nothing needs a timer.
    """

    def __init__(self, grid: OccupancyGrid, config: PlannerConfig | None = None) -> None:
        self.grid = grid
        self.config = config or PlannerConfig()
        self.resolution = grid.resolution
        self._build_static()
        # Time [s] until which each cell holds a live laser obstacle (-inf: none).
        self._marked_until = np.full(grid.cells.shape, -np.inf, dtype=np.float64)
        # (expiry [s], row0, row1, col0, col1) of each batch of marks: the live cells at any
        # time lie in the boxes not yet expired (`_live_box`), so `costs` need not compare the
        # whole grid (a 70 x 35 m floor is a million cells) to find them.
        self._mark_boxes: list[tuple[float, int, int, int, int]] = []
        self._latest_query = -math.inf
        self._cache_key: tuple[float, int] | None = None
        self._cache: npt.NDArray[np.uint8] = self._static_costs
        self._version = 0

    # -- configuration ---------------------------------------------------------------------

    def _build_static(self) -> None:
        """The static layer: obstacles of the a-priori map, their distance field and costs."""
        grid = self.grid
        static = np.ascontiguousarray(
            grid.occupied() if self.config.allow_unknown else grid.blocked()
        )
        static.setflags(write=False)
        self._unknown = (grid.blocked() & ~grid.occupied()) if self.config.allow_unknown else None
        self._static_obstacles = static
        self._static_distance = ndimage.distance_transform_edt(
            ~static, sampling=self.resolution
        ).astype(np.float32)
        self._static_costs = self._costs_from_distance(self._static_distance)
        self._static_costs.setflags(write=False)

    def reconfigure(self, config: PlannerConfig) -> None:
        """Adopt new inflation / obstacle parameters (recomputes the static layer if needed)."""
        old = self.config
        self.config = config
        if old.allow_unknown != config.allow_unknown:
            self._build_static()
        elif (old.inscribed_radius, old.inflation_radius, old.cost_scaling_factor) != (
            config.inscribed_radius,
            config.inflation_radius,
            config.cost_scaling_factor,
        ):
            self._static_costs = self._costs_from_distance(self._static_distance)
            self._static_costs.setflags(write=False)
        self._touch()

    def _costs_from_distance(
        self, distance: npt.NDArray[np.float32], window: tuple[slice, slice] | None = None
    ) -> npt.NDArray[np.uint8]:
        c = self.config
        costs = inflation_cost(
            distance, c.inscribed_radius, c.inflation_radius, c.cost_scaling_factor
        )
        if self._unknown is not None:
            unknown = self._unknown if window is None else self._unknown[window]
            costs[unknown & (costs < UNKNOWN_COST)] = UNKNOWN_COST
        return costs

    def _touch(self) -> None:
        self._version += 1
        self._cache_key = None

    # -- obstacle layer ----------------------------------------------------------------------

    def update(
        self, now: float, pose: Pose2D, scan: LaserScan, sensor: Pose2D | None = None
    ) -> None:
        """Clear the cells the beams pass through, then mark the cells where they end.

        ``pose`` is the robot pose in the map frame, ``sensor`` the laser pose in the robot frame
        (default: at the robot centre, looking forward).
        """
        cfg = self.config
        origin = pose.compose(sensor) if sensor is not None else pose
        c, s = math.cos(origin.yaw), math.sin(origin.yaw)
        valid = scan.valid()
        ranges = scan.ranges.astype(np.float64)
        angles = scan.angles
        # Clearing: sample every other beam (0.5 degrees on the UTM-30LX: under 5 cm apart at
        # the 5 m clearing range, one cell) every cell up to (range - 1 cell). Half-cell steps
        # on every beam cost four times as much for the same cleared cells, give or take one.
        stride = max(1, int(CLEARING_BEAM_SPACING / abs(scan.angle_increment) + 1e-9))
        clear = np.zeros_like(valid)
        clear[::stride] = valid[::stride]
        reach = np.minimum(ranges[clear], cfg.raytrace_max_range) - self.resolution
        beam_angles = angles[clear] + origin.yaw
        if reach.size and float(reach.max()) > 0.0:
            self._clear_beams(now, origin.x, origin.y, beam_angles, reach)
        # Marking: endpoints within obstacle_max_range.
        cos, sin = scan.trig()
        g = self.grid
        until = now + cfg.obstacle_persistence
        box = mark_endpoints(  # scalars as floats: one compiled signature (`jit`)
            self._marked_until,
            valid,
            ranges,
            cos,
            sin,
            float(cfg.obstacle_max_range),
            origin.x,
            origin.y,
            c,
            s,
            float(g.origin_x),
            float(g.origin_y),
            float(g.resolution),
            float(until),
        )
        if box[0] >= 0:
            self._add_box((until, int(box[0]), int(box[1]) + 1, int(box[2]), int(box[3]) + 1), now)
        self._touch()

    def _clear_beams(
        self, now: float, x: float, y: float, angles: FloatArray, reach: FloatArray
    ) -> None:
        """Forget the live marks of the cells that the beams from (x, y) pass through, short of
        their ``reach`` [m], sampled every cell (`clear_live_cells`). Marks not live at ``now``
        are left as they are: clearing them would change nothing at ``now`` or later (a dead
        mark stays dead; time does not go back in the stack)."""
        if not any(box[0] > now for box in self._mark_boxes):
            return  # nothing live to clear
        g = self.grid
        t = np.arange(0.0, float(reach.max()), self.resolution)
        clear_live_cells(  # scalars as floats: one compiled signature (`jit`)
            self._marked_until,
            float(g.origin_x),
            float(g.origin_y),
            float(g.resolution),
            float(x),
            float(y),
            np.cos(angles),
            np.sin(angles),
            t,
            reach,
            float(now),
        )

    def _add_box(self, box: tuple[float, int, int, int, int], now: float) -> None:
        """Remember (expiry, row0, row1, col0, col1) of a batch of marks (`_live_box`)."""
        self._mark_boxes.append(box)
        if len(self._mark_boxes) > 256:  # nobody asked for costs for a while
            self._live_box(now)

    def _live_box(self, now: float) -> tuple[int, int, int, int] | None:
        """(row0, row1, col0, col1) holding every cell live at ``now``, or None to look at the
        whole grid. Boxes that expired are dropped, which is only safe while time does not go
        back: a query before the latest one looks at the whole grid."""
        if now < self._latest_query:
            return None
        self._latest_query = now
        self._mark_boxes = [b for b in self._mark_boxes if b[0] > now]
        if not self._mark_boxes:
            return 0, 0, 0, 0
        boxes = np.array([b[1:] for b in self._mark_boxes])
        return (
            int(boxes[:, 0].min()),
            int(boxes[:, 1].max()),
            int(boxes[:, 2].min()),
            int(boxes[:, 3].max()),
        )

    def remember_near(
        self, now: float, until: float, points: npt.NDArray[np.float64], radius: float
    ) -> int:
        """Keep the live marks within ``radius`` [m] of map-frame ``points`` (N, 2) until
        ``until`` [s] (unless a beam sees through them sooner); returns how many.

        The navigator's memory of a blockage it drives round: out of the laser's sight the marks
        would expire and the plan turn back through it (`navigator` module docstring)."""
        box = self._live_box(now)
        b0, b1, d0, d1 = (0, self.grid.height, 0, self.grid.width) if box is None else box
        rows, cols = np.nonzero(self._marked_until[b0:b1, d0:d1] > now)
        if rows.size == 0 or len(points) == 0:
            return 0
        rows, cols = rows + b0, cols + d0
        x, y = self.grid.cell_to_world(rows, cols)
        gaps = np.hypot(x[:, None] - points[None, :, 0], y[:, None] - points[None, :, 1])
        near = gaps.min(axis=1) <= radius
        rows, cols = rows[near], cols[near]
        later = np.maximum(self._marked_until[rows, cols], until)
        self._marked_until[rows, cols] = later
        if rows.size:
            self._mark_boxes.append(
                (until, int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1)
            )
        self._touch()
        return int(rows.size)

    def clear(self) -> None:
        """Forget every live obstacle (the "clear costmap" recovery)."""
        self._marked_until.fill(-np.inf)
        self._mark_boxes = []
        self._touch()

    def live_obstacles(self, now: float) -> npt.NDArray[np.bool_]:
        """Cells holding an unexpired laser mark."""
        live: npt.NDArray[np.bool_] = self._marked_until > now
        return live

    def obstacles(self, now: float) -> npt.NDArray[np.bool_]:
        """Lethal cells: static obstacles (occupied or unknown) or live laser marks."""
        obstacles: npt.NDArray[np.bool_] = self._static_obstacles | self.live_obstacles(now)
        return obstacles

    def obstacles_window(
        self, now: float, row0: int, row1: int, col0: int, col1: int
    ) -> npt.NDArray[np.bool_]:
        """Lethal cells in ``[row0:row1, col0:col1]`` (clipped to the grid)."""
        h, w = self._static_obstacles.shape
        r0, r1, c0, c1 = max(row0, 0), min(row1, h), max(col0, 0), min(col1, w)
        if r0 >= r1 or c0 >= c1:
            return np.zeros((0, 0), dtype=bool)
        window: npt.NDArray[np.bool_] = self._static_obstacles[r0:r1, c0:c1] | (
            self._marked_until[r0:r1, c0:c1] > now
        )
        return window

    # -- inflation -------------------------------------------------------------------------

    def costs(self, now: float) -> npt.NDArray[np.uint8]:
        """The inflated cost grid at time ``now`` (read-only; 254 lethal, 253 inscribed).

        Only the bounding box of the live obstacles (grown by the inflation radius) is
        recomputed: there the distance is ``min(static distance, distance to live marks)``.
        """
        h, w = self.grid.height, self.grid.width
        box = self._live_box(now)
        b0, b1, d0, d1 = (0, h, 0, w) if box is None else box
        live = self._marked_until[b0:b1, d0:d1] > now
        key = (float(np.count_nonzero(live)), self._version)
        if self._cache_key == key:
            return self._cache
        if not live.any():
            result = self._static_costs
        else:
            rows = np.flatnonzero(live.any(axis=1)) + b0
            cols = np.flatnonzero(live.any(axis=0)) + d0
            pad = math.ceil(self.config.inflation_radius / self.resolution) + 1
            r0, r1 = max(int(rows[0]) - pad, 0), min(int(rows[-1]) + pad + 1, h)
            c0, c1 = max(int(cols[0]) - pad, 0), min(int(cols[-1]) + pad + 1, w)
            live_distance = ndimage.distance_transform_edt(
                ~(self._marked_until[r0:r1, c0:c1] > now), sampling=self.resolution
            )
            distance = np.minimum(self._static_distance[r0:r1, c0:c1], live_distance)
            result = self._static_costs.copy()
            window = (slice(r0, r1), slice(c0, c1))
            result[window] = self._costs_from_distance(distance.astype(np.float32), window)
            result.setflags(write=False)
        self._cache_key = key
        self._cache = result
        return result

    @property
    def static_distance(self) -> npt.NDArray[np.float32]:
        """Distance [m] from each cell to the a-priori map's nearest obstacle (occupied/unknown)."""
        result: npt.NDArray[np.float32] = self._static_distance
        return result

    @property
    def static_costs(self) -> npt.NDArray[np.uint8]:
        """The inflated a-priori map alone."""
        return self._static_costs


@jit.on_warm_up("planning.costmap")
def _warm_up() -> None:
    """A scan marked, then one clearing through the marks: every kernel with its types."""
    grid = OccupancyGrid(np.zeros((40, 40), dtype=np.int8), 0.05, -1.0, -1.0)
    costmap = Costmap(grid)
    ranges = np.full(9, 0.5, dtype=np.float32)
    scan = LaserScan(0.0, -1.0, 0.25, 0.02, 30.0, ranges)
    costmap.update(0.0, Pose2D(0.0, 0.0, 0.0), scan)
    costmap.update(0.1, Pose2D(0.0, 0.0, 0.0), dataclasses.replace(scan, ranges=ranges * 2))
