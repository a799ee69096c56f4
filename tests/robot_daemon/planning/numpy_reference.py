"""The numpy code the planner's compiled kernels replaced (session 13), kept as the tests'
reference: each kernel must give what this code gave, bit for bit (`test_plan_kernels`)."""

from __future__ import annotations

import logging
import math

import cv2
import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import CLEARING_BEAM_SPACING, INSCRIBED, LETHAL, Costmap
from robot_daemon.planning.global_planner import (
    _OFFSETS,
    _STEP,
    MAX_TRAVERSABLE,
    SQRT2,
    GlobalPlanner,
    GoalBlockedError,
    NoPathError,
    PlanningError,
    StartBlockedError,
    _search_box,
    coarsen_costs,
    resample,
)
from robot_daemon.planning.local_planner import (
    CLEARANCE_REF,
    W_CLEARANCE,
    W_HEADING,
    W_PATH,
    W_PROGRESS,
    W_SPEED,
    DWAPlanner,
    LocalPlan,
    ObstacleField,
    _carrot,
    _rollout_with_trig,
    _to_robot_frame,
    limit_step,
    rollout,
)
from robot_daemon.planning.navigator import Navigator

logger = logging.getLogger(__name__)
_WINDOW_MARGIN = 1e-6  # [rad] beyond a cell's exact angular extent, far above rounding


def clearing_samples(
    x: float, y: float, angles: np.ndarray, reach: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """Map-frame points [m] every ``step`` along each beam from (x, y), short of its ``reach``:
    the samples ``t_k = k * step < reach[b]`` of beam ``b``, in beam order."""
    t = np.arange(0.0, float(reach.max()), step)
    counts = np.searchsorted(t, reach, side="left")  # samples with t_k < reach
    beam = np.repeat(np.arange(reach.size), counts)
    starts = np.cumsum(counts) - counts
    k = np.arange(beam.size) - np.repeat(starts, counts)
    tk = t[k]
    xs = x + np.cos(angles)[beam] * tk
    ys = y + np.sin(angles)[beam] * tk
    return xs, ys


class NumpyClearingCostmap(Costmap):
    """`Costmap` marking and clearing as session 12 did: the samples that may land in a live
    mark found with numpy (``_live_clearing_samples``), every cell holding one forgotten, then
    the beams' end cells marked with numpy."""

    def update(
        self, now: float, pose: Pose2D, scan: LaserScan, sensor: Pose2D | None = None
    ) -> None:
        cfg = self.config
        origin = pose.compose(sensor) if sensor is not None else pose
        c, s = math.cos(origin.yaw), math.sin(origin.yaw)
        valid = scan.valid()
        ranges = scan.ranges.astype(np.float64)
        angles = scan.angles
        stride = max(1, int(CLEARING_BEAM_SPACING / abs(scan.angle_increment) + 1e-9))
        clear = np.zeros_like(valid)
        clear[::stride] = valid[::stride]
        reach = np.minimum(ranges[clear], cfg.raytrace_max_range) - self.resolution
        beam_angles = angles[clear] + origin.yaw
        if reach.size and float(reach.max()) > 0.0:
            self._clear_beams(now, origin.x, origin.y, beam_angles, reach)
        mark = valid & (ranges <= cfg.obstacle_max_range)
        cos, sin = scan.trig()
        px, py = ranges[mark] * cos[mark], ranges[mark] * sin[mark]
        wx, wy = origin.x + c * px - s * py, origin.y + s * px + c * py
        rows, cols = self.grid.world_to_cell(wx, wy)
        ok = self.grid.in_bounds(rows, cols)
        self._mark(rows[ok], cols[ok], now, now + cfg.obstacle_persistence)

    def _mark(self, rows: np.ndarray, cols: np.ndarray, now: float, until: float) -> None:
        self._marked_until[rows, cols] = np.maximum(self._marked_until[rows, cols], until)
        if rows.size:
            box = (
                until,
                int(rows.min()),
                int(rows.max()) + 1,
                int(cols.min()),
                int(cols.max()) + 1,
            )
            self._mark_boxes.append(box)
            if len(self._mark_boxes) > 256:  # nobody asked for costs for a while
                self._live_box(now)
        self._touch()

    def _clear_beams(
        self, now: float, x: float, y: float, angles: np.ndarray, reach: np.ndarray
    ) -> None:
        if angles.size > 1 and angles[1] > angles[0]:
            self._clear_cells(*self._live_clearing_samples(now, x, y, angles, reach))
        else:
            self._clear_cells(*clearing_samples(x, y, angles, reach, self.resolution))

    def _live_clearing_samples(
        self, now: float, x: float, y: float, angles: np.ndarray, reach: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The clearing samples that may land in a live mark (``angles`` increasing): a sample
        ``t_k`` along beam ``b`` lies in the cell of centre ``c`` only if ``|t_k - |c - o|| <=
        h`` and the beam passes within ``h`` of ``c`` (``h`` half the cell's diagonal)."""
        res = self.resolution
        g = self.grid
        reach_max = float(reach.max())
        t = np.arange(0.0, reach_max, res)
        empty = np.zeros(0)
        boxes = [b for b in self._mark_boxes if b[0] > now]
        if not boxes:
            return empty, empty
        row_o, col_o = math.floor((y - g.origin_y) / res), math.floor((x - g.origin_x) / res)
        k = math.ceil(reach_max / res) + 2
        r0 = max(row_o - k, min(b[1] for b in boxes), 0)
        r1 = min(row_o + k + 1, max(b[2] for b in boxes), g.height)
        c0 = max(col_o - k, min(b[3] for b in boxes), 0)
        c1 = min(col_o + k + 1, max(b[4] for b in boxes), g.width)
        if r0 >= r1 or c0 >= c1:
            return empty, empty
        live = (self._marked_until[r0:r1, c0:c1] > now).ravel().nonzero()[0]
        if live.size == 0:
            return empty, empty
        rows, cols = np.divmod(live, c1 - c0)
        dx = g.origin_x + (cols + c0 + 0.5) * res - x
        dy = g.origin_y + (rows + r0 + 0.5) * res - y
        rho = np.hypot(dx, dy)
        h = res * math.sqrt(0.5)
        half = np.arcsin(np.minimum(h / np.maximum(rho, 2.0 * h), 0.5)) + _WINDOW_MARGIN
        half[rho <= 2.0 * h] = 2.0 * math.pi
        first = float(angles[0]) - half
        centre = first + np.mod(np.arctan2(dy, dx) - first, 2.0 * math.pi)
        k_lo = np.maximum(np.floor((rho - h) / res).astype(np.int64) - 1, 0)
        k_hi = np.minimum(np.ceil((rho + h) / res).astype(np.int64) + 2, t.size)
        wrap = (centre + 2.0 * math.pi - half <= angles[-1]).nonzero()[0]
        if wrap.size:
            centre = np.concatenate((centre, centre[wrap] + 2.0 * math.pi))
            half = np.concatenate((half, half[wrap]))
            k_lo = np.concatenate((k_lo, k_lo[wrap]))
            k_hi = np.concatenate((k_hi, k_hi[wrap]))
        lo = angles.searchsorted(centre - half)
        n_beams = np.maximum(angles.searchsorted(centre + half, side="right") - lo, 0)
        cell = np.arange(lo.size).repeat(n_beams)
        beam = np.arange(cell.size) + (lo - (n_beams.cumsum() - n_beams)).repeat(n_beams)
        kk = k_lo[cell][:, None] + np.arange(max(int((k_hi - k_lo).max()), 0))[None, :]
        counts = t.searchsorted(reach, side="left")
        real = kk < np.minimum(k_hi[cell], counts[beam])[:, None]
        beam = beam.repeat(np.count_nonzero(real, axis=1))
        tk = t[kk[real]]
        xs = x + np.cos(angles)[beam] * tk
        ys = y + np.sin(angles)[beam] * tk
        return xs, ys

    def _clear_cells(self, xs: np.ndarray, ys: np.ndarray) -> None:
        """Forget the live marks of the cells holding map-frame points (xs, ys) [m]."""
        g = self.grid
        cols = np.floor((xs - g.origin_x) / g.resolution).astype(np.int64)
        rows = np.floor((ys - g.origin_y) / g.resolution).astype(np.int64)
        ok = (rows >= 0) & (rows < g.height) & (cols >= 0) & (cols < g.width)
        self._marked_until[rows[ok], cols[ok]] = -np.inf


class NumpyObstacleField(ObstacleField):
    """`ObstacleField` with session 12's distance (OpenCV's transform, numpy)."""

    def __init__(self, points: npt.ArrayLike, half_size: float, resolution: float) -> None:
        self.half_size = half_size
        self.resolution = resolution
        self.n = math.ceil(2.0 * half_size / resolution)
        self.distance = obstacle_field_distance(np.asarray(points), half_size, resolution)
        bordered = np.full((self.n + 2, self.n + 2), np.inf)
        bordered[1:-1, 1:-1] = self.distance
        self.bordered = bordered.ravel()


class NumpyDWAPlanner(DWAPlanner):
    """`DWAPlanner` with session 12's numpy rollouts: (circles x trajectories x steps) arrays
    of circle centres looked up in the field at once; its field with OpenCV's transform."""

    def make_field(self, obstacles_robot: npt.ArrayLike) -> ObstacleField:
        return NumpyObstacleField(
            obstacles_robot, self.field_half_size(), self.config.local_grid_resolution
        )

    def compute(
        self,
        pose: Pose2D,
        velocity: tuple[float, float],
        path: npt.ArrayLike,
        field: ObstacleField,
        dt: float,
        goal_distance: float | None = None,
    ) -> LocalPlan:
        """The command for the next ``dt`` seconds.

        ``velocity`` is the current (v [m/s], w [rad/s]); ``path`` the global path (N, 2) in the
        map frame; ``field`` the robot-frame obstacle field; ``goal_distance`` [m] is given on
        the final leg (it limits the approach speed).
        """
        c = self.config
        v0, w0 = velocity
        dv, dw = c.linear_acceleration * dt, c.angular_acceleration * dt
        offsets, radius, times = self._shape()
        margin = 0.5 * c.local_grid_resolution
        clearance = self.footprint_clearance(field, 0.0, 0.0, 0.0)

        # Speed limits: near obstacles and on the final approach.
        fraction = min(max(clearance / c.slowdown_clearance, c.slowdown_min_fraction), 1.0)
        v_cap = c.max_linear_speed * fraction
        if goal_distance is not None:
            v_cap = min(
                v_cap,
                max(0.05, c.max_linear_speed * goal_distance / c.approach_slowdown_distance),
            )

        pts = np.asarray(path, dtype=np.float64).reshape(-1, 2)
        local = _to_robot_frame(pts, pose)
        carrot, local_path = _carrot(local, c.lookahead)
        carrot_angle = math.atan2(carrot[1], carrot[0])

        # Turn towards the path first if it lies far off the heading.
        wants_turn = abs(carrot_angle) > c.rotate_to_heading_angle and np.hypot(*carrot) > 1e-3
        if wants_turn:
            w_target = math.copysign(
                max(min(abs(c.yaw_gain * carrot_angle), c.max_angular_speed), c.min_rotation_speed),
                carrot_angle,
            )
            v = limit_step(0.0, v0, dv, min(c.min_linear_speed, 0.0), c.max_linear_speed)
            w = limit_step(w_target, w0, dw, -c.max_angular_speed, c.max_angular_speed)
            x, y, th = rollout(np.array([v]), np.array([w]), times)
            d = field.lookup(
                x[..., None] + np.cos(th)[..., None] * offsets,
                y[..., None] + np.sin(th)[..., None] * offsets,
            )
            if float(d.min()) - radius > margin:
                return LocalPlan(v, w, True, "rotate_to_heading", clearance, 1)

        # The dynamic window.
        v_lo = max(c.min_linear_speed, v0 - dv)
        v_hi = max(v_lo, min(v_cap, v0 + dv))
        w_lo = max(-c.max_angular_speed, w0 - dw)
        w_hi = max(w_lo, min(c.max_angular_speed, w0 + dw))
        # Every (v, w) pair, v-major: np.meshgrid(..., indexing="ij") raveled, without its cost.
        v_s = np.linspace(v_lo, v_hi, c.v_samples).repeat(c.w_samples)
        w_s = np.tile(np.linspace(w_lo, w_hi, c.w_samples), c.v_samples)
        th = w_s[:, None] * times[None, :]
        cos_t, sin_t = np.cos(th), np.sin(th)
        x, y, th = _rollout_with_trig(v_s, times, th, sin_t, cos_t)
        # Circle centres as (circle, trajectory, step): the long axes innermost, for numpy.
        off = offsets[:, None, None]
        d = field.lookup(x[None] + cos_t[None] * off, y[None] + sin_t[None] * off)
        # Over the circles, then the steps: the same minimum, without numpy's slow reduction
        # over two axes at once (twice the cost of this whole line).
        traj_clearance = d.min(axis=0).min(axis=1) - radius
        admissible = traj_clearance > margin
        xe, ye, te = x[:, -1], y[:, -1], th[:, -1]
        mode = "dwa"
        if not admissible.any() and 0.0 < clearance <= margin:
            # Already inside the margin (a map or a pose a few cm off, a person stepping
            # close): every rollout starts there, so none keeps the margin, not even those that
            # lead out, and the robot would brake beside a wall for ever. Admit the ones that
            # stay clear of contact, end farther from the obstacles than the robot is now and
            # nearer the carrot (out along the path, not a crawl along a wall across it).
            end_clearance = d[:, :, -1].min(axis=0) - radius
            nearer = np.hypot(carrot[0] - xe, carrot[1] - ye) < math.hypot(*carrot)
            admissible = (traj_clearance > 0.0) & (end_clearance > clearance) & nearer
            mode = "escape"
        if wants_turn and mode == "dwa":
            room = self._room_to_turn(field, x[:, -1], y[:, -1], admissible, margin)
            if room is not None:
                return LocalPlan(float(v_s[room]), float(w_s[room]), True, "make_room", clearance)
        count = int(admissible.sum())
        if count == 0:
            v = limit_step(0.0, v0, dv, min(c.min_linear_speed, 0.0), c.max_linear_speed)
            w = limit_step(0.0, w0, dw, -c.max_angular_speed, c.max_angular_speed)
            return LocalPlan(v, w, False, "brake", clearance, 0)

        progress = np.hypot(carrot[0] - xe, carrot[1] - ye) / (
            c.lookahead + c.max_linear_speed * c.sim_time
        )
        heading = np.abs(_wrap(np.arctan2(carrot[1] - ye, carrot[0] - xe) - te)) / math.pi
        if local_path.shape[0]:
            gaps = np.hypot(
                xe[:, None] - local_path[None, :, 0], ye[:, None] - local_path[None, :, 1]
            )
            path_term = np.minimum(gaps.min(axis=1) / 0.5, 1.0)
        else:
            path_term = np.zeros_like(xe)
        # np.clip(x, 0, 1) without its wrapper (the same values, NaN and inf included).
        clear_term = np.minimum(np.maximum(1.0 - traj_clearance / CLEARANCE_REF, 0.0), 1.0)
        speed_term = (c.max_linear_speed - v_s) / c.max_linear_speed
        score = (
            W_PROGRESS * progress
            + W_HEADING * heading
            + W_PATH * path_term
            + W_CLEARANCE * clear_term
            + W_SPEED * speed_term
        )
        score = np.where(admissible, score, np.inf)
        best = int(score.argmin())
        return LocalPlan(float(v_s[best]), float(w_s[best]), True, mode, clearance, count)


def numpy_obstacle_points_near(
    obstacles: np.ndarray,
    row0: int,
    col0: int,
    resolution: float,
    origin_x: float,
    origin_y: float,
    pose: Pose2D,
) -> np.ndarray:
    """Session 12's `obstacle_points_near`: robot-frame centres of a window's True cells."""
    rows, cols = obstacles.nonzero()
    x = origin_x + (cols + col0 + 0.5) * resolution
    y = origin_y + (rows + row0 + 0.5) * resolution
    return _to_robot_frame(np.column_stack((x, y)), pose)


class NumpyNavigator(Navigator):
    """`Navigator` on the numpy code the kernels replaced."""

    def _obstacle_field(self, now: float, pose: Pose2D, scan: LaserScan | None) -> ObstacleField:
        half = self.local_planner.field_half_size()
        res = self.grid.resolution
        k = math.ceil(half * math.sqrt(2.0) / res) + 1
        row, col = self.grid.world_to_cell(pose.x, pose.y)
        r0, c0 = int(row) - k, int(col) - k
        window = self.costmap.obstacles_window(now, r0, int(row) + k + 1, c0, int(col) + k + 1)
        pts = numpy_obstacle_points_near(
            window, max(r0, 0), max(c0, 0), res, self.grid.origin_x, self.grid.origin_y, pose
        )
        if scan is not None:
            scan_pts = scan.points(max_range=2.0 * half)
            scan_pts = scan_pts + np.array([self.config.laser_x_offset, 0.0])
            pts = np.vstack((pts, scan_pts))
        self._last_obstacle_points = pts
        return self.local_planner.make_field(pts)

    def __init__(self, grid: OccupancyGrid, config: PlannerConfig | None = None) -> None:
        super().__init__(grid, config)
        self.costmap = NumpyClearingCostmap(grid, self.config)

    def _make_planners(self) -> None:
        super()._make_planners()
        self.global_planner = NumpyGlobalPlanner(self.grid, self.config)
        self.local_planner = NumpyDWAPlanner(self.config)


def exact_distance_transform(free: np.ndarray, resolution: float) -> np.ndarray:
    """Euclidean distance [m] from each cell centre to the nearest zero cell's centre:
    OpenCV's exact transform (``DIST_MASK_PRECISE``) is float32; squaring and rounding
    recovers the integer squared distance in cells."""
    cells = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    squared = np.rint(np.square(cells, dtype=np.float64))
    distance: np.ndarray = np.sqrt(squared) * resolution
    return distance


def obstacle_field_distance(points: np.ndarray, half_size: float, resolution: float) -> np.ndarray:
    """`ObstacleField.distance` as session 12 computed it (with OpenCV)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = math.ceil(2.0 * half_size / resolution)
    idx = np.floor((pts + half_size) / resolution).astype(np.int64)
    ok = (idx >= 0) & (idx < n)
    idx = idx[ok[:, 0] & ok[:, 1]]
    if idx.size == 0:
        return np.full((n, n), np.inf)
    free = np.ones((n, n), dtype=np.uint8)
    free[idx[:, 1], idx[:, 0]] = 0  # [row = y, col = x]
    return exact_distance_transform(free, resolution)


def numpy_reduced_cost_graph(
    costs: npt.NDArray[np.uint8], goal: tuple[int, int], cost_weight: float
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
    int,
]:
    """Session 12's `_reduced_cost_graph`: the CSR arrays of A*'s graph on reduced costs.

    Returns (reduced costs, neighbour node ids, indptr, node cells as flat indices of the
    padded grid, padded cell -> node id, h of each node, padded width). Edges are listed node
    by node in ``_OFFSETS`` order.
    """
    h, w = costs.shape
    # Pad by one lethal cell so that flat neighbour indices never wrap around a row.
    wp = w + 2
    padded = np.full((h + 2, wp), LETHAL, dtype=np.uint8)
    padded[1:-1, 1:-1] = costs
    flat_cost = padded.ravel()
    free_flat = flat_cost < INSCRIBED
    nodes = np.flatnonzero(free_flat)
    compact = np.full(flat_cost.size, -1, dtype=np.int64)
    compact[nodes] = np.arange(nodes.size)
    h_flat = octile_grid((h + 2, wp), (goal[0] + 1, goal[1] + 1)).ravel()
    heuristic = h_flat[nodes]
    offsets = _OFFSETS[:, 0] * wp + _OFFSETS[:, 1]
    neighbours = nodes[:, None] + offsets[None, :]
    traversable = free_flat[neighbours]
    # Dense (nodes x 8) arithmetic first, one masked extraction at the end.
    neighbour_h = h_flat[neighbours]
    cost_f = flat_cost.astype(np.float64)
    weight = _STEP[None, :] * (
        1.0 + (cost_f[nodes][:, None] + cost_f[neighbours]) * (0.5 / cost_weight)
    )
    reduced_dense = weight - heuristic[:, None] + neighbour_h
    reduced = reduced_dense[traversable]
    neighbour_compact = compact[neighbours[traversable]]
    # Consistency makes reduced >= 0; rounding may leave -1e-16, and csgraph needs > 0.
    np.maximum(reduced, 1e-12, out=reduced)
    indptr = np.concatenate(([0], np.cumsum(np.count_nonzero(traversable, axis=1))))
    return reduced, neighbour_compact, indptr, nodes, compact, heuristic, wp


def segment_costs(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    costs: npt.NDArray[np.uint8],
    grid: OccupancyGrid,
) -> npt.NDArray[np.uint8]:
    """Max cost along each segment a[i] -> b[i] (sampled every half cell); (N,) uint8."""
    lengths = np.hypot(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1])
    n = max(2, math.ceil(float(lengths.max(initial=0.0)) / (0.5 * grid.resolution)) + 1)
    t = np.linspace(0.0, 1.0, n)
    xs = a[:, 0, None] + (b[:, 0] - a[:, 0])[:, None] * t[None, :]
    ys = a[:, 1, None] + (b[:, 1] - a[:, 1])[:, None] * t[None, :]
    rows, cols = grid.world_to_cell(xs, ys)
    inside = grid.in_bounds(rows, cols)
    sampled = np.full(xs.shape, LETHAL, dtype=np.uint8)
    sampled[inside] = costs[rows[inside], cols[inside]]
    result: npt.NDArray[np.uint8] = sampled.max(axis=1)
    return result


def numpy_shortcut(
    points: npt.NDArray[np.float64],
    costs: npt.NDArray[np.uint8],
    grid: OccupancyGrid,
    window: int = 120,
) -> npt.NDArray[np.float64]:
    """Session 12's `shortcut`: per kept vertex, every candidate segment sampled at once."""
    n = len(points)
    if n <= 2:
        return points
    vertex_rows, vertex_cols = grid.world_to_cell(points[:, 0], points[:, 1])
    inside = grid.in_bounds(vertex_rows, vertex_cols)
    vertex_cost = np.full(n, LETHAL, dtype=np.int64)
    vertex_cost[inside] = costs[vertex_rows[inside], vertex_cols[inside]]
    # Cost met by the A* path on each leg i -> i+1.
    leg_cost = segment_costs(points[:-1], points[1:], costs, grid).astype(np.int64)
    kept = [0]
    i = 0
    while i < n - 1:
        j_max = min(n - 1, i + window)
        candidates = np.arange(i + 1, j_max + 1)
        allowed = np.maximum.accumulate(
            np.maximum(leg_cost[i:j_max], vertex_cost[i + 1 : j_max + 1])
        )
        allowed = np.maximum(allowed, vertex_cost[i])
        seg = segment_costs(
            np.repeat(points[i : i + 1], candidates.size, axis=0), points[candidates], costs, grid
        ).astype(np.int64)
        ok = (seg <= allowed) & (seg < INSCRIBED)
        ok[0] = True  # the A* leg itself is always acceptable
        j = int(candidates[np.flatnonzero(ok)[-1]])
        kept.append(j)
        i = j
    result: npt.NDArray[np.float64] = points[kept]
    return result


def numpy_astar_cells(
    costs: npt.NDArray[np.uint8],
    start: tuple[int, int],
    goal: tuple[int, int],
    cost_weight: float = 100.0,
) -> tuple[list[tuple[int, int]], float]:
    """Optimal 8-connected path of (row, col) cells on a cost grid, and its cost [cells].

    Cells of cost >= 253 are not traversable. Raises :class:`NoPathError` when the goal cannot
    be reached; start and goal must be traversable.

    Each search with an f-bound ``limit`` builds the graph only on the box that can hold a node
    within the bound (`_search_box`); the nodes keep their order, so the search, ties included,
    is the one on the whole grid.
    """
    h, w = costs.shape
    for name, (r, c) in (("start", start), ("goal", goal)):
        if not (0 <= r < h and 0 <= c < w) or costs[r, c] >= INSCRIBED:
            raise PlanningError(f"{name} cell {(r, c)} is outside the grid or not traversable")
    if start == goal:
        return [start], 0.0
    dr = float(abs(start[0] - goal[0]))
    dc = float(abs(start[1] - goal[1]))
    h_start = max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)  # octile_grid's arithmetic
    # Reduced distance to the goal = path cost - h(start): the detour beyond the straight line.
    limit = max(0.5 * h_start, 20.0)
    reached, previous_limit = -1, 0.0
    # No edge is dearer than this (the exhaustion test below only needs an upper bound).
    max_edge = SQRT2 * (1.0 + MAX_TRAVERSABLE / cost_weight) + SQRT2
    box: tuple[int, int, int, int] | None = None
    while True:
        wanted = _search_box(costs.shape, start, goal, h_start + limit)
        if wanted != box:
            box = wanted
            r0, r1, c0, c1 = box
            sub = costs[r0:r1, c0:c1]
            graph_parts = numpy_reduced_cost_graph(sub, (goal[0] - r0, goal[1] - c0), cost_weight)
            reduced, neighbour_compact, indptr, nodes, compact, _, wp = graph_parts
            graph = csr_matrix((reduced, neighbour_compact, indptr), shape=(nodes.size,) * 2)
            s = int(compact[(start[0] - r0 + 1) * wp + start[1] - c0 + 1])
            g = int(compact[(goal[0] - r0 + 1) * wp + goal[1] - c0 + 1])
        dist, pred = dijkstra(graph, indices=s, return_predecessors=True, limit=limit)
        if math.isfinite(dist[g]) or limit == math.inf:
            break
        now_reached = int(np.count_nonzero(np.isfinite(dist)))
        if now_reached == reached and limit - previous_limit > max_edge:
            break  # nothing new within a band wider than any edge: the region is exhausted
        reached, previous_limit = now_reached, limit
        limit = limit * 4.0 if limit < 4.0 * h_start + 100.0 else math.inf
    if not math.isfinite(dist[g]):
        raise NoPathError(f"no traversable path from cell {start} to cell {goal}")
    chain = [g]
    while chain[-1] != s:
        chain.append(int(pred[chain[-1]]))
    chain.reverse()
    cells_flat = nodes[np.asarray(chain)]
    rows, cols = np.divmod(cells_flat, wp)
    cells = [(int(r) - 1 + r0, int(c) - 1 + c0) for r, c in zip(rows, cols, strict=True)]
    total = float(dist[g]) + h_start  # undo the potential: cost = reduced + h(s) - h(g), h(g)=0
    return cells, total


class NumpyGlobalPlanner(GlobalPlanner):
    """`GlobalPlanner` with session 12's numpy graph and shortcutting."""

    def plan(
        self,
        costs: npt.NDArray[np.uint8],
        start: tuple[float, float],
        goal: tuple[float, float],
    ) -> list[tuple[float, float]]:
        """A path of map-frame points [m] from ``start`` to ``goal`` on the fine cost grid.

        The first point is the start (or, if it lay in inscribed space, the nearest free
        point), the last the goal; points are about ``sample_spacing`` apart.
        """
        grid = self.grid
        if costs.shape != grid.cells.shape:
            raise ValueError(f"cost grid shape {costs.shape} != map shape {grid.cells.shape}")
        start_cost = self._fine_cost(costs, start)
        goal_cost = self._fine_cost(costs, goal)
        if start_cost == LETHAL:
            raise StartBlockedError(
                f"start ({start[0]:.2f}, {start[1]:.2f}) is in an obstacle or outside"
                f" {grid.source}; move the robot or relocalise"
            )
        if goal_cost == LETHAL:
            raise GoalBlockedError(
                f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is in an obstacle, unknown space or outside"
                f" {grid.source}; pick a goal in free space"
            )
        windows = [self._window(start, goal, costs.shape), None]
        for window in windows:
            r0, r1, c0, c1 = window or (0, costs.shape[0], 0, costs.shape[1])
            coarse = coarsen_costs(costs[r0:r1, c0:c1], self.factor)
            offset = (r0 // self.factor, c0 // self.factor)
            start_cell = self._snap(coarse, start, "start", offset)
            goal_cell = self._snap(coarse, goal, "goal", offset)
            try:
                cells, _ = numpy_astar_cells(coarse, start_cell, goal_cell, self.config.cost_weight)
                break
            except NoPathError as exc:
                if window is None:
                    raise NoPathError(
                        f"no path from ({start[0]:.2f}, {start[1]:.2f}) to "
                        f"({goal[0]:.2f}, {goal[1]:.2f}) in {grid.source}: "
                        "they are separated by obstacles"
                    ) from exc
                logger.debug("no path inside the search window; searching the whole map")
        rows = np.array([c[0] for c in cells], dtype=np.float64) + offset[0]
        cols = np.array([c[1] for c in cells], dtype=np.float64) + offset[1]
        points = np.column_stack(
            (
                grid.origin_x + (cols + 0.5) * self.coarse_resolution,
                grid.origin_y + (rows + 0.5) * self.coarse_resolution,
            )
        )
        # Replace the end cells' centres by the true start/goal where those are traversable.
        if start_cost < INSCRIBED:
            points[0] = start
        if goal_cost < INSCRIBED:
            points[-1] = goal
        if len(points) == 1:
            points = np.vstack((points, points))
        points = numpy_shortcut(points, costs, grid)
        resampled = resample(points, self.config.path_spacing)
        return [(float(x), float(y)) for x, y in resampled]


def numpy_shadow_mask(
    ranges: np.ndarray,
    angle_increment: float,
    min_angle: float = math.radians(10.0),
    window: int = 1,
) -> np.ndarray:
    """Session 12's `shadow_mask`: the veiling points of ``ranges``, with numpy."""
    r = np.asarray(ranges, dtype=np.float64)
    finite = np.isfinite(r) & (r > 0)
    bad = np.zeros(r.shape, dtype=bool)
    lo, hi = min_angle, math.pi - min_angle
    for k in range(1, window + 1):
        d_phi = k * angle_increment
        for a, b in ((slice(None, -k), slice(k, None)), (slice(k, None), slice(None, -k))):
            ri, rj = r[a], r[b]
            both = finite[a] & finite[b]
            with np.errstate(invalid="ignore"):
                alpha = np.arctan2(rj * math.sin(d_phi), ri - rj * math.cos(d_phi))
            shadow = both & ((alpha < lo) | (alpha > hi))
            # As laser_filters does: of a shadow pair, drop the farther point (the veil), keep
            # the nearer one (the obstacle's true edge).
            bad[a] |= shadow & (ri > rj)
            bad[b] |= shadow & (rj > ri)
    return bad


def octile_grid(shape: tuple[int, int], goal: tuple[int, int]) -> npt.NDArray[np.float64]:
    """Octile distance [cells] from every cell of a grid of ``shape`` to ``goal`` = (row, col).

    Computed from one row and one column of distances (broadcast), element for element the
    same arithmetic as the formula on each cell (the tests' reference): gathering from this grid is cheaper than evaluating
    the formula on every (node, neighbour) pair.
    """
    dr = np.abs(np.arange(shape[0], dtype=np.int64) - goal[0]).astype(np.float64)[:, None]
    dc = np.abs(np.arange(shape[1], dtype=np.int64) - goal[1]).astype(np.float64)[None, :]
    result: npt.NDArray[np.float64] = np.maximum(dr, dc) + (SQRT2 - 1.0) * np.minimum(dr, dc)
    return result


def _wrap(angle: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    wrapped: npt.NDArray[np.float64] = (angle + np.pi) % (2.0 * np.pi) - np.pi
    return wrapped
