"""Global path planning: A* on an (optionally coarsened) inflated costmap, then smoothing.

The first stage of the Hybrid Motion Planner's global planner (thesis §3.3.2): "the A* algorithm
[25] in the low resolution costmap ... a quick approximation of a feasible path", followed by
smoothing (§3.3.2.1; here line-of-sight shortcutting instead of elastic bands).

Search. 8-connected grid, step cost ``len * (1 + (c_u + c_v) / (2 * cost_weight))`` with ``len``
1 or sqrt(2) cells times the resolution [m] and ``c`` the Nav2 cell costs; cells of cost >= 253
(inscribed or lethal) are not traversable. A* with the octile heuristic
``h = res * (max(dx, dy) + (sqrt(2) - 1) * min(dx, dy))`` (admissible and consistent, since every
step costs at least its length) is run as Dijkstra on the *reduced* costs
``w'(u, v) = w(u, v) - h(u) + h(v) >= 0`` (the potential-function view of A*, Hart, Nilsson and
Raphael 1968; Johnson 1977): the compiled ``scipy.sparse.csgraph.dijkstra`` then expands nodes in
A*'s order, and its ``limit`` argument stops the search at an f-value bound that grows fourfold
until the goal is reached, so only A*'s ellipse around the straight line is explored; the graph
itself is built only on the box that holds that ellipse (`_search_box`), with the nodes in the
same order, so the search and its ties are those on the whole grid; its edges come from a
compiled loop (`reduced_cost_edges`, `robot_daemon.jit`).

Coarsening. With ``planning_resolution`` a multiple ``f`` of the map resolution, each coarse cell
takes the *maximum* cost of its ``f x f`` fine cells (conservative: a coarse cell is free only if
all its fine cells are). A 0.9 m door still leaves a band of free coarse cells at 0.1 m.

Smoothing. Greedy line-of-sight shortcutting on the fine cost grid: from each anchor the path jumps
to the farthest later vertex whose straight segment stays out of inscribed space and never meets a
cost higher than the highest cost the A* path itself met between the two vertices (so a shortcut
never hugs a wall more closely than the optimal path did), in one compiled loop
(`shortcut_kept`). The result is resampled every ``sample_spacing`` metres.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon import jit
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import INSCRIBED, LETHAL, MAX_NON_LETHAL

logger = logging.getLogger(__name__)

SQRT2 = math.sqrt(2.0)
# 8-connected neighbourhood (d_row, d_col) and step lengths [cells].
_OFFSETS = np.array(
    [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)], dtype=np.int64
)
_STEP = np.hypot(_OFFSETS[:, 0], _OFFSETS[:, 1])
MAX_TRAVERSABLE = float(MAX_NON_LETHAL)  # the dearest cell a path may cross


class PlanningError(RuntimeError):
    """No path can be planned; subclasses say why."""


class StartBlockedError(PlanningError):
    """The start lies in an obstacle (or in inscribed space with no free cell nearby)."""


class GoalBlockedError(PlanningError):
    """The goal lies in an obstacle, in inscribed space or outside the map."""


class NoPathError(PlanningError):
    """Start and goal are in different free regions of the costmap."""


SNAP_RADIUS = 0.5  # [m] how far a start/goal in inscribed space may be moved
# [m] Search first in the box around start and goal grown by this margin; only if that box holds
# no path is the whole map searched. Legs between topological nodes are 5-20 m, so this cuts a
# plan on a 70 x 35 m floor from ~50 ms to a few ms.
WINDOW_MARGIN = 8.0


def coarsen_costs(costs: npt.NDArray[np.uint8], factor: int) -> npt.NDArray[np.uint8]:
    """Max-pool ``costs`` over ``factor x factor`` blocks; a partial edge block counts as lethal
    where it runs off the map."""
    if factor == 1:
        return costs
    h, w = costs.shape
    hc, wc = -(-h // factor), -(-w // factor)
    padded = np.full((hc * factor, wc * factor), LETHAL, dtype=np.uint8)
    padded[:h, :w] = costs
    # f*f strided maxima are several times faster than reshape(...).max(axis=(1, 3)).
    pooled: npt.NDArray[np.uint8] = padded[::factor, ::factor].copy()
    for dr in range(factor):
        for dc in range(factor):
            if dr or dc:
                np.maximum(pooled, padded[dr::factor, dc::factor], out=pooled)
    return pooled


def _reduced_cost_graph(
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
    """The CSR arrays of `astar_cells`' graph on the reduced costs ``w(u, v) - h(u) + h(v)``.

    Returns (reduced costs, neighbour node ids, indptr, node cells as flat indices of the
    padded grid, padded cell -> node id, h of each node, padded width). Edges are listed node
    by node in ``_OFFSETS`` order (`reduced_cost_edges`).
    """
    h, w = costs.shape
    # Pad by one lethal cell so that flat neighbour indices never wrap around a row.
    wp = w + 2
    padded = np.full((h + 2, wp), LETHAL, dtype=np.uint8)
    padded[1:-1, 1:-1] = costs
    flat_cost = padded.ravel()
    nodes = np.flatnonzero(flat_cost < INSCRIBED)
    reduced, neighbour_compact, indptr, compact, heuristic = reduced_cost_edges(
        flat_cost, nodes, wp, goal[0] + 1, goal[1] + 1, _OFFSETS, _STEP, float(cost_weight)
    )
    return reduced, neighbour_compact, indptr, nodes, compact, heuristic, wp


@jit.kernel
def reduced_cost_edges(
    flat_cost: npt.NDArray[np.uint8],
    nodes: npt.NDArray[np.int64],
    wp: int,
    goal_row: int,
    goal_col: int,
    offsets: npt.NDArray[np.int64],
    step: npt.NDArray[np.float64],
    cost_weight: float,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
]:
    """The edges of the padded grid's traversable ``nodes`` (flat indices, row width ``wp``)
    to their traversable neighbours, node by node in ``offsets`` order, with the reduced cost

        w'(u, v) = step * (1 + (c_u + c_v) * (0.5 / cost_weight)) - h(u) + h(v)

    (at least 1e-12: consistency makes it >= 0 but rounding may leave -1e-16, and csgraph
    needs > 0), ``h`` the octile distance to the goal cell (`_octile`).
    Returns (reduced costs, neighbour node ids, indptr, padded cell -> node id or -1, h of
    each node).
    """
    compact = np.full(flat_cost.size, -1, dtype=np.int64)
    for i in range(nodes.size):
        compact[nodes[i]] = i
    heuristic = np.empty(nodes.size)
    for i in range(nodes.size):
        heuristic[i] = _octile(nodes[i] // wp, nodes[i] % wp, goal_row, goal_col)
    flat_offsets = offsets[:, 0] * wp + offsets[:, 1]
    indptr = np.empty(nodes.size + 1, dtype=np.int64)
    indptr[0] = 0
    for i in range(nodes.size):
        count = 0
        for k in range(flat_offsets.size):
            if compact[nodes[i] + flat_offsets[k]] >= 0:
                count += 1
        indptr[i + 1] = indptr[i] + count
    reduced = np.empty(indptr[-1])
    neighbour = np.empty(indptr[-1], dtype=np.int64)
    half_over_weight = 0.5 / cost_weight
    e = 0
    for i in range(nodes.size):
        u = nodes[i]
        for k in range(flat_offsets.size):
            v = u + flat_offsets[k]
            if compact[v] < 0:
                continue
            weight = step[k] * (
                1.0 + (float(flat_cost[u]) + float(flat_cost[v])) * half_over_weight
            )
            h_v = _octile(v // wp, v % wp, goal_row, goal_col)
            reduced[e] = max(weight - heuristic[i] + h_v, 1e-12)
            neighbour[e] = compact[v]
            e += 1
    return reduced, neighbour, indptr, compact, heuristic


@jit.kernel
def _octile(row: int, col: int, goal_row: int, goal_col: int) -> float:
    """Octile distance [cells] between two cells: ``max(dr, dc) + (sqrt(2) - 1) min(dr, dc)``."""
    dr = float(abs(row - goal_row))
    dc = float(abs(col - goal_col))
    return max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)


def astar_cells(
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
    h_start = max(dr, dc) + (SQRT2 - 1.0) * min(dr, dc)  # `_octile`'s arithmetic
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
            graph_parts = _reduced_cost_graph(sub, (goal[0] - r0, goal[1] - c0), cost_weight)
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


def _search_box(
    shape: tuple[int, ...], start: tuple[int, int], goal: tuple[int, int], bound: float
) -> tuple[int, int, int, int]:
    """(row0, row1, col0, col1) of the cells a search with f-bound ``bound`` [cells] can reach
    or relax, clipped to the grid (all of it for an infinite bound).

    A node n within the bound has ``octile(s, n) + octile(n, g) <= bound`` (a path is at least
    its octile length), and ``octile >= |d_row|``, so ``|r - r_s| + |r - r_g| <= bound``:
    ``r`` lies within ``(bound - |r_s - r_g|) / 2`` of the segment [r_s, r_g]; the same for
    columns. One more cell holds the neighbours the search relaxes, one more is for rounding.
    """
    if not math.isfinite(bound):
        return 0, shape[0], 0, shape[1]
    box = []
    for axis in (0, 1):
        low, high = sorted((start[axis], goal[axis]))
        slack = math.ceil(max(bound - (high - low), 0.0) / 2.0) + 2
        box += [max(low - slack, 0), min(high + slack + 1, shape[axis])]
    return box[0], box[1], box[2], box[3]


class GlobalPlanner:
    """Plans map-frame paths on cost grids with the geometry of ``grid``."""

    def __init__(self, grid: OccupancyGrid, config: PlannerConfig | None = None) -> None:
        """``config``: its planning_resolution, cost_weight (step cost = length x (1 + cost /
        cost_weight)) and path_spacing (of the returned points)."""
        self.grid = grid
        self.config = config or PlannerConfig()
        self.factor = max(1, round(self.config.planning_resolution / grid.resolution))
        self.coarse_resolution = self.factor * grid.resolution

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
                cells, _ = astar_cells(coarse, start_cell, goal_cell, self.config.cost_weight)
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
        points = shortcut(points, costs, grid)
        resampled = resample(points, self.config.path_spacing)
        return [(float(x), float(y)) for x, y in resampled]

    def _fine_cost(self, costs: npt.NDArray[np.uint8], point: tuple[float, float]) -> int:
        row, col = self.grid.world_to_cell(point[0], point[1])
        if not bool(self.grid.in_bounds(row, col)):
            return LETHAL
        return int(costs[int(row), int(col)])

    def _window(
        self, start: tuple[float, float], goal: tuple[float, float], shape: tuple[int, ...]
    ) -> tuple[int, int, int, int]:
        """Fine-grid (row0, row1, col0, col1) of the search box, aligned to coarse blocks."""
        grid, f = self.grid, self.factor
        margin = WINDOW_MARGIN
        xs, ys = (start[0], goal[0]), (start[1], goal[1])
        rows, cols = grid.world_to_cell(
            [min(xs) - margin, max(xs) + margin], [min(ys) - margin, max(ys) + margin]
        )
        r0 = max(int(rows[0]) // f * f, 0)
        c0 = max(int(cols[0]) // f * f, 0)
        r1 = min((int(rows[1]) // f + 1) * f, shape[0])
        c1 = min((int(cols[1]) // f + 1) * f, shape[1])
        return r0, r1, c0, c1

    def _snap(
        self,
        coarse: npt.NDArray[np.uint8],
        point: tuple[float, float],
        name: str,
        offset: tuple[int, int] = (0, 0),
    ) -> tuple[int, int]:
        """The coarse cell of ``point`` in ``coarse`` (whose cell (0, 0) is the full coarse
        grid's ``offset``), or the nearest traversable one within snap_radius."""
        grid = self.grid
        res = self.coarse_resolution
        col = math.floor((point[0] - grid.origin_x) / res) - offset[1]
        row = math.floor((point[1] - grid.origin_y) / res) - offset[0]
        h, w = coarse.shape
        if 0 <= row < h and 0 <= col < w and coarse[row, col] < INSCRIBED:
            return row, col
        k = max(1, math.ceil(SNAP_RADIUS / res))
        r0, r1 = max(row - k, 0), min(row + k + 1, h)
        c0, c1 = max(col - k, 0), min(col + k + 1, w)
        window = coarse[r0:r1, c0:c1]
        rr, cc = np.nonzero(window < INSCRIBED)
        if rr.size:
            cx = grid.origin_x + (cc + c0 + offset[1] + 0.5) * res
            cy = grid.origin_y + (rr + r0 + offset[0] + 0.5) * res
            d = np.hypot(cx - point[0], cy - point[1])
            best = int(np.argmin(d))
            if d[best] <= SNAP_RADIUS + res:
                logger.debug("%s snapped %.2f m to a free cell", name, float(d[best]))
                return int(rr[best] + r0), int(cc[best] + c0)
        error = StartBlockedError if name == "start" else GoalBlockedError
        raise error(
            f"{name} ({point[0]:.2f}, {point[1]:.2f}) is within the robot's inscribed radius of an"
            f" obstacle and no free cell lies within {SNAP_RADIUS} m"
        )


def shortcut(
    points: npt.NDArray[np.float64],
    costs: npt.NDArray[np.uint8],
    grid: OccupancyGrid,
    window: int = 120,
) -> npt.NDArray[np.float64]:
    """Greedy line-of-sight shortcutting that respects the costmap (see module docstring;
    `shortcut_kept`)."""
    if len(points) <= 2:
        return points
    read_only = costs.view()  # as the costmap's grids are: one compiled signature (`jit`)
    read_only.setflags(write=False)
    kept = shortcut_kept(
        np.ascontiguousarray(points, dtype=np.float64),
        read_only,
        float(grid.origin_x),
        float(grid.origin_y),
        float(grid.resolution),
        int(window),
    )
    result: npt.NDArray[np.float64] = points[kept]
    return result


@jit.kernel
def shortcut_kept(
    points: npt.NDArray[np.float64],
    costs: npt.NDArray[np.uint8],
    origin_x: float,
    origin_y: float,
    resolution: float,
    window: int,
) -> npt.NDArray[np.int64]:
    """Indices of the path vertices the shortcutting keeps: from each kept vertex ``i`` the
    farthest of the next ``window`` vertices ``j`` whose segment's highest cost
    (`segment_max_costs`) is below inscribed and no higher than the highest the path met
    from ``i`` to ``j`` (its legs and vertices; ``j = i + 1`` always qualifies)."""
    n = points.shape[0]
    height, width = costs.shape
    vertex_cost = np.empty(n, dtype=np.int64)
    for i in range(n):
        col = math.floor((points[i, 0] - origin_x) / resolution)
        row = math.floor((points[i, 1] - origin_y) / resolution)
        inside = 0 <= row < height and 0 <= col < width
        vertex_cost[i] = costs[row, col] if inside else LETHAL
    legs = (np.ascontiguousarray(points[:-1]), np.ascontiguousarray(points[1:]))
    leg_cost = segment_max_costs(*legs, costs, origin_x, origin_y, resolution)
    kept = [0]
    i = 0
    while i < n - 1:
        j_max = min(n - 1, i + window)
        ends = np.ascontiguousarray(points[i + 1 : j_max + 1])
        starts = np.empty_like(ends)
        starts[:, 0] = points[i, 0]
        starts[:, 1] = points[i, 1]
        seg = segment_max_costs(starts, ends, costs, origin_x, origin_y, resolution)
        allowed = vertex_cost[i]
        best = i + 1  # the path's own leg is always acceptable
        for q in range(j_max - i):
            allowed = max(allowed, leg_cost[i + q], vertex_cost[i + 1 + q])
            if seg[q] <= allowed and seg[q] < INSCRIBED:
                best = i + 1 + q
        kept.append(best)
        i = best
    return np.array(kept, dtype=np.int64)


@jit.kernel
def segment_max_costs(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    costs: npt.NDArray[np.uint8],
    origin_x: float,
    origin_y: float,
    resolution: float,
) -> npt.NDArray[np.int64]:
    """Highest cost along each segment a[i] -> b[i] (N, 2) [m], LETHAL off the grid.

    Every segment is sampled at the same ``m`` fractions ``t = numpy.linspace(0, 1, m)``
    (``k * (1 / (m - 1))``, the last exactly 1), ``m`` giving the longest segment a sample
    every half cell: ``m = max(2, ceil(longest / (res / 2)) + 1)``.
    """
    longest = 0.0
    for s in range(a.shape[0]):
        longest = max(longest, math.hypot(b[s, 0] - a[s, 0], b[s, 1] - a[s, 1]))
    m = max(2, math.ceil(longest / (0.5 * resolution)) + 1)
    step = 1.0 / (m - 1)
    height, width = costs.shape
    result = np.empty(a.shape[0], dtype=np.int64)
    for s in range(a.shape[0]):
        dx, dy = b[s, 0] - a[s, 0], b[s, 1] - a[s, 1]
        highest = 0
        for k in range(m):
            t = 1.0 if k == m - 1 else k * step
            col = math.floor((a[s, 0] + dx * t - origin_x) / resolution)
            row = math.floor((a[s, 1] + dy * t - origin_y) / resolution)
            inside = 0 <= row < height and 0 <= col < width
            highest = max(highest, int(costs[row, col]) if inside else LETHAL)
        result[s] = highest
    return result


def resample(points: npt.NDArray[np.float64], spacing: float) -> npt.NDArray[np.float64]:
    """Points every ``spacing`` metres along the polyline, always keeping both ends."""
    seg = np.hypot(np.diff(points[:, 0]), np.diff(points[:, 1]))
    s = np.concatenate(([0.0], np.cumsum(seg)))
    total = float(s[-1])
    if total <= 0.0:
        return points[:1].copy()
    count = max(1, math.ceil(total / spacing))
    targets = np.linspace(0.0, total, count + 1)
    xs = np.interp(targets, s, points[:, 0])
    ys = np.interp(targets, s, points[:, 1])
    result: npt.NDArray[np.float64] = np.column_stack((xs, ys))
    return result


@jit.on_warm_up("planning.global_planner")
def _warm_up() -> None:
    costs = np.zeros((5, 6), dtype=np.uint8)
    costs[1:4, 2] = LETHAL
    astar_cells(costs, (2, 0), (2, 5))
    grid = OccupancyGrid(np.zeros((5, 6), dtype=np.int8), 0.1, 0.0, 0.0)
    shortcut(np.array([[0.05, 0.05], [0.25, 0.15], [0.55, 0.45]]), costs, grid)
