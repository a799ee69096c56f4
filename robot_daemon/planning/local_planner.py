"""Local planning with the dynamic window approach (Fox, Burgard and Thrun 1997).

Fox et al., "The dynamic window approach to collision avoidance", IEEE Robotics & Automation
Magazine 4(1), 1997; the D-DWA of the Hybrid Motion Planner (thesis §3.3.2.2) is a variant.

Search space. Velocities reachable within one control period ``dt`` under the acceleration limits
(the *dynamic window*) intersected with the speed limits::

    V_d = [v0 - a_v dt, v0 + a_v dt] x [w0 - a_w dt, w0 + a_w dt]
    V_s = [v_min, v_max] x [-w_max, w_max]

sampled ``v_samples x w_samples`` times. Each (v, w) is held for ``sim_time`` seconds; the robot
moves on a circular arc ``x = v/w sin(w t)``, ``y = v/w (1 - cos(w t))``, ``theta = w t``.

Admissibility. The rectangular footprint (``robot_length x robot_width``) is covered by ``n``
circles on its long axis (radius ``sqrt((L / 2n)^2 + (W / 2)^2)``); a pose collides when the
Euclidean distance transform of a robot-centred obstacle grid (live scan points and the
costmap's lethal cells) at a circle centre is below its radius. The grid's distance is exact
(`obstacle_distance`, Felzenszwalb and Huttenlocher's transform); each trajectory is rolled out
and looked up step by step, circle by circle, in a compiled loop (`rollout_clearance`,
`robot_daemon.jit`), and so is the objective's minimum (`best_trajectory`). A trajectory keeps
half a grid cell of margin;
when the robot already stands inside that margin (none can keep it) but clear of contact, the
*escape* trajectories are admissible instead: clear of contact throughout, ending farther from
the obstacles and nearer the carrot than the robot is now.

Objective (lower is better; Fox's heading, dist and velocity terms, DWB-style)::

    G = w_prog * |p_end - carrot| + w_head * |angle to carrot| + w_path * d(p_end, path)
        + w_clear * max(0, 1 - clearance / 0.2 m) + w_speed * (v_max - v) / v_max

where the *carrot* is the path point ``lookahead`` metres past the point nearest the robot.
The speed limit shrinks with the footprint's clearance (doors, people) and, on the final leg, with
the distance to the goal. A path heading error beyond ``rotate_to_heading_angle`` is first
turned away in place (as Nav2's rotation shim does); where that turn is not admissible, the
robot first drives to the most open place within reach (`DWAPlanner._room_to_turn`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D, wrap_angle
from robot_daemon import jit
from robot_daemon.planning.config import PlannerConfig

FloatArray = npt.NDArray[np.float64]

# Weights of the objective's terms.
W_PROGRESS = 1.0
W_HEADING = 0.05
W_PATH = 0.1
W_CLEARANCE = 0.4
W_SPEED = 0.2
# Clearance [m] below which a trajectory is penalised. Small on purpose: a larger reference makes
# every longer (faster) trajectory through a door look worse than standing still.
CLEARANCE_REF = 0.2


@dataclass(frozen=True)
class LocalPlan:
    """One control decision: the command and why."""

    linear: float  # [m/s]
    angular: float  # [rad/s]
    valid: bool  # False: no admissible trajectory; the command brakes
    mode: str  # "dwa", "escape", "rotate_to_heading", "make_room", "rotate_to_goal" or "brake"
    clearance: float  # [m] footprint clearance at the current pose
    admissible: int = 0  # number of collision-free trajectories


def footprint_circles(length: float, width: float) -> tuple[npt.NDArray[np.float64], float]:
    """Centres (x offsets [m]) and common radius [m] of circles covering the rectangle."""
    n = max(1, math.ceil(2.0 * length / width))
    segment = length / n
    offsets: npt.NDArray[np.float64] = -0.5 * length + segment * (
        np.arange(n, dtype=np.float64) + 0.5
    )
    radius = math.hypot(0.5 * segment, 0.5 * width)
    return offsets, radius


class ObstacleField:
    """Distance [m] to the nearest obstacle point, on a square robot-centred grid
    (`obstacle_distance`)."""

    def __init__(self, points: npt.ArrayLike, half_size: float, resolution: float) -> None:
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        self.half_size = half_size
        self.resolution = resolution
        self.n = math.ceil(2.0 * half_size / resolution)
        # The distance with a border of inf cells, flat: `lookup` clips indices to the border
        # instead of masking the points outside (one gather).
        self.bordered: FloatArray = obstacle_distance(
            pts, float(half_size), float(resolution), self.n
        )
        self.distance: FloatArray = self.bordered.reshape(self.n + 2, self.n + 2)[1:-1, 1:-1]

    def lookup(self, x: npt.ArrayLike, y: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Distance at robot-frame points; outside the grid counts as far from everything."""
        col = self._cells(x)
        row = self._cells(y)
        # Cell k of the grid is k + 1 of the bordered one; anything outside lands on the border.
        # minimum/maximum in place: np.clip's wrapper costs more than the clipping.
        np.minimum(col, self.n, out=col)
        np.maximum(col, -1, out=col)
        np.minimum(row, self.n, out=row)
        np.maximum(row, -1, out=row)
        row *= self.n + 2
        row += col
        row += self.n + 3  # (row + 1) * (n + 2) + col + 1
        result: npt.NDArray[np.float64] = self.bordered.take(row)
        return result

    def _cells(self, coordinate: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """``floor((coordinate + half_size) / resolution)``, in place on one temporary."""
        u = np.add(coordinate, self.half_size, dtype=np.float64)
        u /= self.resolution
        np.floor(u, out=u)
        cells: npt.NDArray[np.int64] = u.astype(np.int64)
        return cells


@jit.kernel
def obstacle_distance(
    points: FloatArray, half_size: float, resolution: float, n: int
) -> FloatArray:
    """Euclidean distance [m] from each cell centre of an ``n x n`` grid of side
    ``2 * half_size`` [m] centred on the robot to the nearest cell holding one of the robot-
    frame ``points`` (N, 2) (``inf`` with none), with a border of ``inf`` cells round it,
    flattened: ``(n + 2) ** 2`` values, row = y.

    A point is in cell ``floor((p + half_size) / resolution)``. The squared distance in cells
    is exact in integers (Felzenszwalb and Huttenlocher, "Distance transforms of sampled
    functions", Theory of Computing 8, 2012): per column the squared distance to the nearest
    obstacle of that column, ``g``, then per row the lower envelope of the parabolas
    ``g(q) + (c - q)**2``; the distance is ``sqrt(k) * resolution``, as OpenCV's exact
    transform squared and rounded gave it (session 12), and scipy's ``distance_transform_edt``
    to a unit or two in the last place.
    """
    bordered = np.full((n + 2) * (n + 2), math.inf)
    occupied = np.zeros((n, n), dtype=np.bool_)
    anything = False
    for p in range(points.shape[0]):
        col = math.floor((points[p, 0] + half_size) / resolution)
        row = math.floor((points[p, 1] + half_size) / resolution)
        if 0 <= col < n and 0 <= row < n:
            occupied[row, col] = True
            anything = True
    if not anything:
        return bordered
    none = 4 * n * n + 1  # more than any squared distance within the grid
    g = np.empty((n, n), dtype=np.int64)
    for c in range(n):  # down and up each column: the nearest obstacle cell in it
        gap = -1
        for r in range(n):
            gap = 0 if occupied[r, c] else (gap + 1 if gap >= 0 else -1)
            g[r, c] = gap * gap if gap >= 0 else none
        gap = -1
        for r in range(n - 1, -1, -1):
            gap = 0 if occupied[r, c] else (gap + 1 if gap >= 0 else -1)
            if gap >= 0 and gap * gap < g[r, c]:
                g[r, c] = gap * gap
    apex = np.empty(n, dtype=np.int64)  # the parabolas of the lower envelope
    start = np.empty(n + 1)  # where each begins to be the lowest
    for r in range(n):
        k = -1
        for q in range(n):
            if g[r, q] == none:
                continue
            s = -math.inf
            while k >= 0:
                a = apex[k]
                s = ((g[r, q] + q * q) - (g[r, a] + a * a)) / (2.0 * (q - a))
                if s > start[k]:
                    break
                k -= 1
            k += 1
            apex[k] = q
            start[k] = s if k > 0 else -math.inf
        if k < 0:
            continue  # no obstacle reaches this row (nor any: every column was empty)
        start[k + 1] = math.inf
        j = 0
        for c in range(n):
            while start[j + 1] < c:
                j += 1
            a = apex[j]
            squared = (c - a) * (c - a) + g[r, a]
            bordered[(r + 1) * (n + 2) + c + 1] = math.sqrt(float(squared)) * resolution
    return bordered


def rollout(
    v: npt.NDArray[np.float64], w: npt.NDArray[np.float64], times: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Poses (x, y, theta), each (S, K), of S constant-(v, w) arcs at K times, from the origin."""
    theta = w[:, None] * times[None, :]
    return _rollout_with_trig(v, times, theta, np.sin(theta), np.cos(theta))


def _rollout_with_trig(
    v: npt.NDArray[np.float64],
    times: npt.NDArray[np.float64],
    theta: npt.NDArray[np.float64],
    sin_t: npt.NDArray[np.float64],
    cos_t: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """`rollout` from ``sin(theta)`` and ``cos(theta)`` computed once by the caller (who needs
    them again for the footprint circles). Where ``theta`` is not small ``sin(safe)`` is
    ``sin(theta)``; where it is, the ratios are replaced by their limits, as `rollout` does."""
    dist = v[:, None] * times[None, :]
    small = np.abs(theta) < 1e-9
    safe = np.where(small, 1.0, theta)
    sin_ratio = np.where(small, 1.0, sin_t / safe)
    cos_ratio = np.where(small, 0.5 * theta, (1.0 - cos_t) / safe)
    return dist * sin_ratio, dist * cos_ratio, theta


@jit.kernel
def rollout_clearance(
    v: FloatArray,
    w: FloatArray,
    times: FloatArray,
    cos_t: FloatArray,
    sin_t: FloatArray,
    offsets: FloatArray,
    bordered: FloatArray,
    n: int,
    half_size: float,
    resolution: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Every arc (v[i], w[j]), v-major, rolled out (`rollout`; ``cos_t``, ``sin_t`` are the
    caller's ``cos`` and ``sin`` of ``w[:, None] * times``) with the footprint's circles at
    each step looked up in an `ObstacleField` (its ``bordered`` grid): one trajectory at a
    time, where numpy needed (circles x trajectories x steps) arrays.

    Returns (x_end, y_end, d_min, d_end) of each arc: its end point, the least distance [m]
    over every circle and step, and over the circles at the last step. The arithmetic is
    `_rollout_with_trig`'s and `ObstacleField.lookup`'s, operation for operation.
    """
    steps = times.size
    x_end = np.empty(v.size * w.size)
    y_end = np.empty(v.size * w.size)
    d_min = np.empty(v.size * w.size)
    d_end = np.empty(v.size * w.size)
    stride = n + 2
    for i in range(v.size):
        for j in range(w.size):
            least = last = math.inf
            x = y = 0.0
            for k in range(steps):
                theta = w[j] * times[k]
                dist = v[i] * times[k]
                c, s = cos_t[j, k], sin_t[j, k]
                if abs(theta) < 1e-9:  # the limits of the ratios on a straight line
                    x = dist * 1.0
                    y = dist * (0.5 * theta)
                else:
                    x = dist * (s / theta)
                    y = dist * ((1.0 - c) / theta)
                last = math.inf
                for offset in offsets:
                    col = math.floor((x + c * offset + half_size) / resolution)
                    row = math.floor((y + s * offset + half_size) / resolution)
                    col = max(min(col, n), -1)  # outside the grid: onto its border of inf
                    row = max(min(row, n), -1)
                    d = bordered[row * stride + col + stride + 1]
                    least = min(least, d)
                    last = min(last, d)
            arc = i * w.size + j
            x_end[arc], y_end[arc], d_min[arc], d_end[arc] = x, y, least, last
    return x_end, y_end, d_min, d_end


@jit.kernel
def best_trajectory(
    v: FloatArray,
    w: FloatArray,
    horizon: float,
    x_end: FloatArray,
    y_end: FloatArray,
    bearing: FloatArray,
    clearance: FloatArray,
    admissible: npt.NDArray[np.bool_],
    carrot_x: float,
    carrot_y: float,
    path: FloatArray,
    reach: float,
    max_speed: float,
) -> int:
    """The admissible arc (v[i], w[j]) (index ``i * w.size + j``) of least objective (the
    module docstring's ``G``; the first of equals), -1 if none is admissible:

        progress = |p_end - carrot| / reach,  heading = |wrap(bearing - w * horizon)| / pi,
        path = min(d(p_end, path) / 0.5, 1),  clear = clip(1 - clearance / CLEARANCE_REF, 0, 1),
        speed = (max_speed - v) / max_speed,

    ``bearing`` being numpy's ``arctan2`` of the carrot from each end point (a compiled
    ``atan2`` may differ in the last bits; ``hypot`` is the C library's in both, and ``%`` is
    Python's floored remainder, numpy's too).
    """
    best = -1
    best_score = math.inf
    for i in range(v.size):
        speed_term = (max_speed - v[i]) / max_speed
        for j in range(w.size):
            k = i * w.size + j
            if not admissible[k]:
                continue
            progress = math.hypot(carrot_x - x_end[k], carrot_y - y_end[k]) / reach
            heading = abs((bearing[k] - w[j] * horizon + math.pi) % (2.0 * math.pi) - math.pi)
            heading = heading / math.pi
            path_term = 0.0
            if path.shape[0]:
                gap = math.inf
                for p in range(path.shape[0]):
                    gap = min(gap, math.hypot(x_end[k] - path[p, 0], y_end[k] - path[p, 1]))
                path_term = min(gap / 0.5, 1.0)
            clear_term = min(max(1.0 - clearance[k] / CLEARANCE_REF, 0.0), 1.0)
            score = (
                W_PROGRESS * progress
                + W_HEADING * heading
                + W_PATH * path_term
                + W_CLEARANCE * clear_term
                + W_SPEED * speed_term
            )
            if score < best_score:
                best, best_score = k, score
    return best


def limit_step(target: float, current: float, max_step: float, low: float, high: float) -> float:
    """``target`` clipped to ``[low, high]`` and to within ``max_step`` of ``current``."""
    return float(min(max(min(max(target, low), high), current - max_step), current + max_step))


class DWAPlanner:
    """Dynamic window local planner; stateless apart from its configuration."""

    def __init__(self, config: PlannerConfig | None = None) -> None:
        self.config = config or PlannerConfig()
        # `_shape`'s values, for the configuration object they were computed from.
        self._shape_of: PlannerConfig | None = None
        self._shape_cache: tuple[npt.NDArray[np.float64], float, npt.NDArray[np.float64]]

    def _shape(self) -> tuple[npt.NDArray[np.float64], float, npt.NDArray[np.float64]]:
        """The footprint's circles (`footprint_circles`) and the rollout times (`_times`) of
        the current configuration: computed once per configuration, not on every cycle."""
        if self._shape_of is not self.config:
            c = self.config
            offsets, radius = footprint_circles(c.robot_length, c.robot_width)
            times = _times(c)
            offsets.setflags(write=False)
            times.setflags(write=False)
            self._shape_cache = (offsets, radius, times)
            self._shape_of = c
        return self._shape_cache

    def field_half_size(self) -> float:
        """Half side [m] of the robot-centred obstacle grid: covers every rollout."""
        c = self.config
        reach = max(c.max_linear_speed, abs(c.min_linear_speed)) * c.sim_time
        return reach + math.hypot(0.5 * c.robot_length, 0.5 * c.robot_width) + 0.6

    def make_field(self, obstacles_robot: npt.ArrayLike) -> ObstacleField:
        return ObstacleField(
            obstacles_robot, self.field_half_size(), self.config.local_grid_resolution
        )

    def footprint_clearance(self, field: ObstacleField, x: float, y: float, yaw: float) -> float:
        """Clearance [m] of the footprint (circle cover) at a robot-frame pose (<0: collision)."""
        offsets, radius, _ = self._shape()
        d = field.lookup(x + math.cos(yaw) * offsets, y + math.sin(yaw) * offsets)
        return float(d.min() - radius)

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
        _, radius, times = self._shape()
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
            _, _, turn_distance, _ = self._rollouts(np.array([v]), np.array([w]), field)
            if float(turn_distance[0]) - radius > margin:
                return LocalPlan(v, w, True, "rotate_to_heading", clearance, 1)

        # The dynamic window.
        v_lo = max(c.min_linear_speed, v0 - dv)
        v_hi = max(v_lo, min(v_cap, v0 + dv))
        w_lo = max(-c.max_angular_speed, w0 - dw)
        w_hi = max(w_lo, min(c.max_angular_speed, w0 + dw))
        # Every (v, w) pair, v-major (pair k is (v_grid[k // w_samples], w_grid[k % w_samples])).
        v_grid = np.linspace(v_lo, v_hi, c.v_samples)
        w_grid = np.linspace(w_lo, w_hi, c.w_samples)
        xe, ye, distance, end_distance = self._rollouts(v_grid, w_grid, field)
        traj_clearance = distance - radius
        admissible = traj_clearance > margin
        mode = "dwa"
        if not admissible.any() and 0.0 < clearance <= margin:
            # Already inside the margin (a map or a pose a few cm off, a person stepping
            # close): every rollout starts there, so none keeps the margin, not even those that
            # lead out, and the robot would brake beside a wall for ever. Admit the ones that
            # stay clear of contact, end farther from the obstacles than the robot is now and
            # nearer the carrot (out along the path, not a crawl along a wall across it).
            end_clearance = end_distance - radius
            nearer = np.hypot(carrot[0] - xe, carrot[1] - ye) < math.hypot(*carrot)
            admissible = (traj_clearance > 0.0) & (end_clearance > clearance) & nearer
            mode = "escape"
        if wants_turn and mode == "dwa":
            room = self._room_to_turn(field, xe, ye, admissible, margin)
            if room is not None:
                v, w = v_grid[room // c.w_samples], w_grid[room % c.w_samples]
                return LocalPlan(float(v), float(w), True, "make_room", clearance)
        count = int(admissible.sum())
        if count == 0:
            v = limit_step(0.0, v0, dv, min(c.min_linear_speed, 0.0), c.max_linear_speed)
            w = limit_step(0.0, w0, dw, -c.max_angular_speed, c.max_angular_speed)
            return LocalPlan(v, w, False, "brake", clearance, 0)
        best = best_trajectory(
            v_grid,
            w_grid,
            float(times[-1]),
            xe,
            ye,
            np.arctan2(carrot[1] - ye, carrot[0] - xe),  # numpy's, as before (see the kernel)
            traj_clearance,
            admissible,
            float(carrot[0]),
            float(carrot[1]),
            np.ascontiguousarray(local_path),
            float(c.lookahead + c.max_linear_speed * c.sim_time),
            float(c.max_linear_speed),
        )
        v, w = v_grid[best // c.w_samples], w_grid[best % c.w_samples]
        return LocalPlan(float(v), float(w), True, mode, clearance, count)

    def _rollouts(
        self, v: FloatArray, w: FloatArray, field: ObstacleField
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """`rollout_clearance` of the arcs (v[i], w[j]), v-major, over this configuration's
        horizon: their end points (x, y), the least obstacle distance [m] of the footprint's
        circles along each and at its end."""
        offsets, _, times = self._shape()
        theta = w[:, None] * times[None, :]
        return rollout_clearance(
            v,
            w,
            times,
            np.cos(theta),
            np.sin(theta),
            offsets,
            field.bordered,
            field.n,
            float(field.half_size),
            float(field.resolution),
        )

    def _room_to_turn(
        self,
        field: ObstacleField,
        xe: npt.NDArray[np.float64],
        ye: npt.NDArray[np.float64],
        admissible: npt.NDArray[np.bool_],
        margin: float,
    ) -> int | None:
        """The admissible trajectory that ends where the robot has most room to turn in place,
        when it has not that room here: or None (room enough, or nowhere with more).

        Turning in place sweeps the circle of radius ``max|offset| + radius`` of the footprint's
        circles. The path lies behind the robot but the turn is not admissible where it stands
        (a 1.3-1.4 m corridor, off its centre line, or a person beside it); and the objective
        cannot get it out: without reversing every move takes it away from the path, and the
        turns that stay admissible over the horizon are the slowest (Willow seeds 6 and 8:
        0.04 rad/s for tens of seconds). So it first drives to the most open place within reach.
        """
        offsets, radius, _ = self._shape()
        sweep = float(np.abs(offsets).max()) + radius
        here = float(field.lookup(np.zeros(1), np.zeros(1))[0]) - sweep
        if here > margin:
            return None
        room = np.where(admissible, field.lookup(xe, ye) - sweep, -np.inf)
        best = int(room.argmax())
        return best if room[best] > here + 0.5 * margin else None

    def rotate_to_yaw(
        self, pose: Pose2D, goal_yaw: float, angular_velocity: float, dt: float
    ) -> tuple[float, bool]:
        """In-place rotation to ``goal_yaw``: (w [rad/s], aligned).

        ``w = clip(k * e, +-w_max)`` with ``|w| >= min_rotation_speed`` and
        ``|w| <= sqrt(2 a_w |e|)`` (can still stop in time), acceleration-limited; aligned (and
        w = 0) once ``|e| <= goal_yaw_tolerance``.
        """
        c = self.config
        error = wrap_angle(goal_yaw - pose.yaw)
        dw = c.angular_acceleration * dt
        if abs(error) <= c.goal_yaw_tolerance:
            return limit_step(
                0.0, angular_velocity, dw, -c.max_angular_speed, c.max_angular_speed
            ), True
        magnitude = min(
            abs(c.yaw_gain * error),
            c.max_angular_speed,
            math.sqrt(2.0 * c.angular_acceleration * abs(error)),
        )
        magnitude = max(magnitude, c.min_rotation_speed)
        w = limit_step(
            math.copysign(magnitude, error),
            angular_velocity,
            dw,
            -c.max_angular_speed,
            c.max_angular_speed,
        )
        return w, False


def _times(config: PlannerConfig) -> npt.NDArray[np.float64]:
    steps = max(1, round(config.sim_time / config.sim_dt))
    times: npt.NDArray[np.float64] = config.sim_dt * np.arange(1, steps + 1, dtype=np.float64)
    return times


def _to_robot_frame(points: npt.NDArray[np.float64], pose: Pose2D) -> npt.NDArray[np.float64]:
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    dx, dy = points[:, 0] - pose.x, points[:, 1] - pose.y
    local: npt.NDArray[np.float64] = np.column_stack((c * dx + s * dy, -s * dx + c * dy))
    return local


def _carrot(
    local: npt.NDArray[np.float64], lookahead: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The point ``lookahead`` metres along the path past its point nearest the robot, and the
    path points from the nearest one up to ``2 * lookahead`` further (robot frame)."""
    if local.shape[0] == 0:
        return np.zeros(2), local
    nearest = int(np.hypot(local[:, 0], local[:, 1]).argmin())
    ahead = local[nearest:]
    seg = np.hypot(np.diff(ahead[:, 0]), np.diff(ahead[:, 1]))
    s = np.concatenate(([0.0], seg.cumsum()))
    if s[-1] <= lookahead:
        carrot = ahead[-1]
    else:
        carrot = np.array(
            [np.interp(lookahead, s, ahead[:, 0]), np.interp(lookahead, s, ahead[:, 1])]
        )
    window = ahead[s <= 2.0 * lookahead]
    return carrot, window


def obstacle_points_near(
    obstacles: npt.NDArray[np.bool_],
    row0: int,
    col0: int,
    resolution: float,
    origin_x: float,
    origin_y: float,
    pose: Pose2D,
    scan_points: npt.NDArray[np.float64] | None = None,
    laser_x: float = 0.0,
) -> npt.NDArray[np.float64]:
    """Robot-frame centres (N, 2) [m] of the True cells of a map window starting at (row0, col0),
    then the laser's ``scan_points`` (M, 2) (its frame, ``laser_x`` [m] ahead of the centre)
    (`robot_frame_points`)."""
    extra = np.zeros((0, 2)) if scan_points is None else scan_points
    return robot_frame_points(
        np.ascontiguousarray(obstacles, dtype=np.bool_),
        int(row0),
        int(col0),
        float(resolution),
        float(origin_x),
        float(origin_y),
        pose.x,
        pose.y,
        math.cos(pose.yaw),
        math.sin(pose.yaw),
        np.ascontiguousarray(extra, dtype=np.float64),
        float(laser_x),
    )


@jit.kernel
def robot_frame_points(
    obstacles: npt.NDArray[np.bool_],
    row0: int,
    col0: int,
    resolution: float,
    origin_x: float,
    origin_y: float,
    x: float,
    y: float,
    c: float,
    s: float,
    laser_points: FloatArray,
    laser_x: float,
) -> FloatArray:
    """The centres of the True cells of a map window (row-major; cell (r, c) of the window is
    map cell (row0 + r, col0 + c)) in the frame of a robot at (x, y) with heading (c, s) =
    (cos, sin), ``(c * dx + s * dy, -s * dx + c * dy)``, then ``laser_points`` moved
    ``laser_x`` [m] forward: (N + M, 2) [m]."""
    rows, cols = obstacles.shape
    count = 0
    for r in range(rows):
        for k in range(cols):
            if obstacles[r, k]:
                count += 1
    out = np.empty((count + laser_points.shape[0], 2))
    i = 0
    for r in range(rows):
        for k in range(cols):
            if obstacles[r, k]:
                dx = origin_x + (k + col0 + 0.5) * resolution - x
                dy = origin_y + (r + row0 + 0.5) * resolution - y
                out[i, 0] = c * dx + s * dy
                out[i, 1] = -s * dx + c * dy
                i += 1
    for p in range(laser_points.shape[0]):
        out[i + p, 0] = laser_points[p, 0] + laser_x
        out[i + p, 1] = laser_points[p, 1] + 0.0
    return out


@jit.on_warm_up("planning.local_planner")
def _warm_up() -> None:
    """Plans on a straight path (the trajectory choice), one behind the robot (the turn to
    it) and the obstacle points round a robot: every kernel with its types."""
    window = np.eye(3, dtype=np.bool_)
    obstacle_points_near(window, 0, 0, 0.05, 0.0, 0.0, Pose2D(0.0, 0.0, 0.0), np.ones((2, 2)))
    planner = DWAPlanner(PlannerConfig())
    field = planner.make_field(np.array([[2.0, 2.0]]))
    path = np.array([[0.0, 0.0], [2.0, 0.0]])
    planner.compute(Pose2D(0.0, 0.0, 0.0), (0.1, 0.0), path, field, 0.1)  # "dwa"
    planner.compute(Pose2D(0.0, 0.0, 3.0), (0.0, 0.0), path, field, 0.1)  # "rotate_to_heading"
