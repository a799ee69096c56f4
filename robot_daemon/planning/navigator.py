"""The navigator: costmap + global A* + DWA + goal checking + recoveries, as a state machine.

The role of the thesis's ``hybrid_motion_planner`` node (§4.2.3.2): from the current pose, the
a-priori map and the laser scan it computes the speed commands that take Interbot to the goal,
avoiding static and dynamic obstacles, with configurable speed limits and goal tolerances
(Table 6.3). The behaviour around it follows Nav2's default behaviour tree: replan at about 1 Hz
(and at once when the local planner finds no admissible trajectory); a progress checker (less than
``progress_distance`` in ``progress_timeout``) starts the recoveries *clear costmap -> spin -> back
up -> wait*, in turn; when ``blocked_timeout`` passes without progress the navigator stops and
reports ``blocked`` with a reason instead of oscillating. A recovery episode ends once the robot
has got away from where it began (past a goal, or ``progress_distance`` from there and nearer
the goal): edging through a door as people step aside in turn is progress, shuttling is not.

Detours. Live obstacles are lethal in the global plan, so a person standing in a 1.4 m corridor
closes it and the planner sends the robot the other way round the building (Willow, issue 12:
6 m ahead or 21 m back, flipping as people stepped in and out; the robot turned round in the
corridor, again and again, until it was reported blocked). As Nav2's ``PathLongerOnApproach``
does, a plan more than ``DETOUR_LENGTH_FACTOR`` times as long as the plan in the a-priori map
alone is not taken at once: the robot keeps to the a-priori path (the local planner stops short
of whoever is in the way) for as long as the detour's extra length would take to drive (the
rent-or-buy rule: waiting can then cost at most twice the better choice), and never longer than
``progress_timeout``. A blockage that outlasts that is driven round, and remembered for as long
as the detour takes (out of sight its marks would expire and the plan turn back through it);
moving ``progress_distance`` on gives the next blockage its own patience.

Pure and deterministic: time is passed to every call (``now`` [s], monotonic); the caller runs
:meth:`Navigator.update` at the controller rate (10-20 Hz) and sends the returned command.

States: ``idle`` (no goal), ``planning`` (goal set, no path yet), ``following``, ``rotating``
(within the xy tolerance of the final goal, turning to its yaw), ``recovering``, ``blocked``,
``succeeded``.
"""

from __future__ import annotations

import enum
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.topics import Tolerance, YawTolerance
from robot_daemon.planning.bottleneck import free_width, widest_way
from robot_daemon.planning.config import PlannerConfig, PlannerConfigError
from robot_daemon.planning.costmap import LETHAL, Costmap
from robot_daemon.planning.global_planner import (
    WINDOW_MARGIN,
    GlobalPlanner,
    GoalBlockedError,
    PlanningError,
)
from robot_daemon.planning.goal_checker import next_goal_index
from robot_daemon.planning.local_planner import (
    DWAPlanner,
    ObstacleField,
    limit_step,
    obstacle_points_near,
)
from robot_daemon.planning.scan_filter import remove_shadows

logger = logging.getLogger(__name__)

RECOVERY_SEQUENCE = ("clear_costmap", "spin", "back_up", "wait")
STUCK_TIME = 2.0  # [s] without an admissible trajectory before a recovery starts
# A plan this many times as long as the a-priori map's is a detour round a blockage (Nav2's
# PathLongerOnApproach ``length_factor`` default); going round a box or a person is shorter.
DETOUR_LENGTH_FACTOR = 2.0
DEFAULT_DT = 0.1  # [s] assumed control period before the second update


class NavState(enum.StrEnum):
    IDLE = "idle"
    PLANNING = "planning"
    FOLLOWING = "following"
    ROTATING = "rotating"
    RECOVERING = "recovering"
    BLOCKED = "blocked"
    SUCCEEDED = "succeeded"


@dataclass(frozen=True)
class NavCommand:
    """What to send to the base now, and the navigator's state."""

    linear: float  # [m/s]
    angular: float  # [rad/s]
    state: NavState
    reason: str = ""
    goal_index: int = 0  # index of the current goal in the route (0 for a single goal)


@dataclass
class _Behaviour:
    name: str
    started: float
    start_pose: Pose2D


def path_length(points: npt.NDArray[np.float64]) -> float:
    """Length [m] of a polyline (N, 2)."""
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


class Navigator:
    """Drives to a goal or along a route of goals on ``grid``; see the module docstring."""

    def __init__(self, grid: OccupancyGrid, config: PlannerConfig | None = None) -> None:
        self.grid = grid
        self.config = config or PlannerConfig()
        self.costmap = Costmap(grid, self.config)
        self._make_planners()
        self._goals: tuple[Pose2D, ...] = ()
        self._index = 0
        self._approach_tolerance = self.config.approach_tolerance
        self._xy_tolerance = self.config.goal_xy_tolerance
        self._yaw_tolerance = self.config.goal_yaw_tolerance
        self._state = NavState.IDLE
        self._reason = ""
        self._path: npt.NDArray[np.float64] | None = None
        self._last_plan_time = -math.inf
        self._last_time: float | None = None
        self._command = (0.0, 0.0)
        self._progress_pose: Pose2D | None = None
        self._progress_time = 0.0
        self._stuck_since: float | None = None
        self._last_obstacle_points: npt.NDArray[np.float64] | None = None
        self._episode_start: float | None = None
        self._episode_pose: Pose2D | None = None
        self._episode_index = 0
        self._recovery_step = 0
        self._behaviour: _Behaviour | None = None
        # Detours (module docstring): when the current blockage was first planned round, and
        # whether the robot has given up waiting for it and drives round.
        self._hold_since: float | None = None
        self._detouring = False
        self._holding_reason = ""

    # -- commands from the daemon ------------------------------------------------------------

    def _make_planners(self) -> None:
        self.global_planner = GlobalPlanner(self.grid, self.config)
        self.local_planner = DWAPlanner(self.config)

    def reconfigure(self, **changes: Any) -> PlannerConfig:
        """Change parameters at run time (validated; raises :class:`PlannerConfigError`)."""
        new = self.config.replace(**changes)
        self.config = new
        self.costmap.reconfigure(new)
        self._make_planners()
        if "goal_xy_tolerance" in changes:
            self._xy_tolerance = new.goal_xy_tolerance
        if "goal_yaw_tolerance" in changes:
            self._yaw_tolerance = new.goal_yaw_tolerance
        if "approach_tolerance" in changes:
            self._approach_tolerance = new.approach_tolerance
        self._path = None
        logger.info("navigation reconfigured: %s", changes)
        return new

    def set_route(
        self,
        poses: Sequence[Pose2D],
        approach_tolerance: float | None = None,
        goal_xy_tol: float | None = None,
        goal_yaw_tol: float | None = None,
        now: float | None = None,
    ) -> None:
        """Drive through ``poses``: intermediate goals count as reached within
        ``approach_tolerance`` [m]; the last within ``goal_xy_tol`` [m] and ``goal_yaw_tol``
        [rad]. Tolerances default to the configuration's; given ones are declared as the
        route message declares them."""
        if not poses:
            raise ValueError("set_route needs at least one pose")
        tolerances = (
            ("approach_tolerance", approach_tolerance, self.config.approach_tolerance, Tolerance),
            ("goal_xy_tol", goal_xy_tol, self.config.goal_xy_tolerance, Tolerance),
            ("goal_yaw_tol", goal_yaw_tol, self.config.goal_yaw_tolerance, YawTolerance),
        )
        self._approach_tolerance, self._xy_tolerance, self._yaw_tolerance = (
            default
            if value is None
            else schema.checked(value, type_, f"set_route.{name}", PlannerConfigError)
            for name, value, default, type_ in tolerances
        )
        self._goals = tuple(poses)
        self._index = 0
        self._state = NavState.PLANNING
        self._reason = ""
        self._path = None
        self._reset_recovery()
        self._reset_detour()
        self._progress_pose = None
        if now is not None:
            self._progress_time = now
        logger.info("new route of %d goal(s), final %s", len(poses), poses[-1])

    def cancel(self) -> None:
        """Stop navigating; the next update returns zero velocity in state ``idle``."""
        self._goals = ()
        self._state = NavState.IDLE
        self._reason = "cancelled"
        self._path = None
        self._reset_recovery()
        self._reset_detour()

    # -- read-only views ----------------------------------------------------------------------

    @property
    def state(self) -> NavState:
        return self._state

    @property
    def path(self) -> list[tuple[float, float]]:
        """The current global path (map frame) or [] when there is none."""
        if self._path is None:
            return []
        return [(float(x), float(y)) for x, y in self._path]

    @property
    def goal_index(self) -> int:
        return self._index

    # -- the control step ---------------------------------------------------------------------

    def update(self, now: float, pose: Pose2D, scan: LaserScan | None = None) -> NavCommand:
        """One control cycle: integrate the scan, plan if due, return the command."""
        dt = DEFAULT_DT if self._last_time is None else min(max(now - self._last_time, 1e-3), 0.5)
        self._last_time = now
        cfg = self.config
        sensor = Pose2D(cfg.laser_x_offset, 0.0, 0.0)
        if scan is not None:
            scan = remove_shadows(scan)  # mixed pixels would close doors in the costmap
            self.costmap.update(now, pose, scan, sensor)
        if self._state in (NavState.IDLE, NavState.SUCCEEDED, NavState.BLOCKED):
            return self._emit(0.0, 0.0)
        if self._progress_pose is None:
            self._progress_pose, self._progress_time = pose, now

        # Intermediate goals: advance within the approach tolerance (`goal_checker`).
        last = len(self._goals) - 1
        index = next_goal_index(self._goals, self._index, pose, self._approach_tolerance)
        if index != self._index:
            logger.info("intermediate goal(s) %d..%d reached", self._index, index - 1)
            self._index = index
            self._path = None
            self._reset_detour()
            self._progress_pose, self._progress_time = pose, now
        target = self._goals[self._index]
        final = self._index == last

        if self._state is NavState.RECOVERING:
            return self._run_recovery(now, pose, scan, dt)

        if final and (
            self._state is NavState.ROTATING or pose.distance_to(target) <= self._xy_tolerance
        ):
            return self._rotate_to_goal(now, pose, target, dt)

        # Global plan: on a new goal, periodically, and sooner when stuck.
        if self._path is None or now - self._last_plan_time >= cfg.replan_period:
            failure = self._plan(now, pose, target)
            if failure is not None:
                return failure

        field = self._obstacle_field(now, pose, scan)
        assert self._path is not None
        goal_distance = pose.distance_to(target) if final else None
        plan = self.local_planner.compute(pose, self._command, self._path, field, dt, goal_distance)
        self._state = NavState.FOLLOWING
        if not plan.valid:
            self._stuck_since = now if self._stuck_since is None else self._stuck_since
            if now - self._last_plan_time >= 0.5 * cfg.replan_period:
                self._path = None  # replan on the next cycle
            if now - self._stuck_since >= STUCK_TIME:
                self._stuck_since = None
                return self._start_recovery(now, pose, "no collision-free trajectory")
        else:
            self._stuck_since = None

        # Progress checker.
        if pose.distance_to(self._progress_pose) >= cfg.progress_distance:
            self._progress_pose, self._progress_time = pose, now
            self._reset_recovery()
            if not self._detouring:
                self._hold_since = None  # got on: the next blockage gets its own patience
        elif now - self._progress_time > cfg.progress_timeout:
            return self._start_recovery(
                now,
                pose,
                f"less than {cfg.progress_distance} m progress in {cfg.progress_timeout} s",
            )
        reason = self._holding_reason
        if not plan.valid:
            reason = "; ".join(filter(None, ("braking: no admissible trajectory", reason)))
        return self._emit(plan.linear, plan.angular, reason)

    # -- pieces of the cycle ------------------------------------------------------------------

    def _emit(self, linear: float, angular: float, reason: str | None = None) -> NavCommand:
        self._command = (linear, angular)
        if reason is not None:
            self._reason = reason
        return NavCommand(linear, angular, self._state, self._reason, self._index)

    def _plan(self, now: float, pose: Pose2D, target: Pose2D) -> NavCommand | None:
        """Plan to ``target``; on failure return the command of the failure handling."""
        costs = self.costmap.costs(now)
        self._last_plan_time = now
        try:
            points = self.global_planner.plan(costs, (pose.x, pose.y), (target.x, target.y))
        except PlanningError as exc:
            if self._unreachable_in_static_map(pose, target, exc):
                self._state = NavState.BLOCKED
                self._path = None
                why = f"{exc}; {self._narrowest_way(pose, target)}"
                logger.warning("goal %d unreachable: %s", self._index, why)
                return self._emit(0.0, 0.0, f"goal unreachable in the map: {why}")
            self._path = None
            return self._start_recovery(now, pose, f"no path: {exc}")
        self._path = self._wait_or_detour(now, pose, target, costs, np.asarray(points, dtype=float))
        return None

    def _reset_detour(self) -> None:
        self._hold_since = None
        self._detouring = False
        self._holding_reason = ""

    def _wait_or_detour(
        self,
        now: float,
        pose: Pose2D,
        target: Pose2D,
        costs: npt.NDArray[np.uint8],
        live: npt.NDArray[np.float64],
    ) -> npt.NDArray[np.float64]:
        """The path to follow: ``live`` (planned with the live obstacles), or the a-priori map's
        path while waiting for a blockage to clear before a detour (module docstring)."""
        self._holding_reason = ""
        static_costs = self.costmap.static_costs
        live_length = path_length(live)
        direct = math.hypot(target.x - pose.x, target.y - pose.y)
        if costs is static_costs or live_length <= DETOUR_LENGTH_FACTOR * direct:
            self._detouring = False  # no plan could be that much shorter: not a detour
            return live
        try:
            points = self.global_planner.plan(static_costs, (pose.x, pose.y), (target.x, target.y))
        except PlanningError:
            return live  # the a-priori map has no better way: nothing to wait for
        static = np.asarray(points, dtype=np.float64)
        extra = live_length - path_length(static)
        if live_length <= DETOUR_LENGTH_FACTOR * path_length(static):
            self._detouring = False
            return live
        if self._detouring:
            return live
        if self._hold_since is None:
            self._hold_since = now
            logger.info("the way ahead is blocked (a detour %.1f m longer): waiting", extra)
        patience = min(extra / self.config.max_linear_speed, self.config.progress_timeout)
        if now - self._hold_since >= patience:
            self._detouring = True
            # Remember what blocks the way for as long as the detour takes to drive: out of
            # the laser's sight it would be forgotten and the plan turn back through it.
            remembered = self.costmap.remember_near(
                now,
                now + live_length / self.config.max_linear_speed,
                static,
                self.config.inflation_radius,
            )
            logger.info(
                "the way ahead stayed blocked for %.0f s: taking the detour (%.1f m longer;"
                " %d blocking cells remembered)",
                now - self._hold_since,
                extra,
                remembered,
            )
            return live
        self._holding_reason = (
            f"waiting for the way ahead to clear (a detour would be {extra:.1f} m longer)"
        )
        return static

    def _unreachable_in_static_map(self, pose: Pose2D, target: Pose2D, exc: PlanningError) -> bool:
        """Whether ``exc`` would happen without live obstacles too (recoveries cannot help)."""
        if isinstance(exc, GoalBlockedError):
            row, col = self.grid.world_to_cell(target.x, target.y)
            if not bool(self.grid.in_bounds(row, col)):
                return True
            if int(self.costmap.static_costs[int(row), int(col)]) == LETHAL:
                return True
        try:
            self.global_planner.plan(
                self.costmap.static_costs, (pose.x, pose.y), (target.x, target.y)
            )
        except PlanningError:
            return True
        return False

    def _narrowest_way(self, pose: Pose2D, target: Pose2D) -> str:
        """Where the widest way from ``pose`` to ``target`` in the a-priori map is narrowest
        (`bottleneck`), searched in the global planner's window: the "where and why" of an
        unreachable goal."""
        grid = self.grid
        margin = WINDOW_MARGIN
        xs, ys = (pose.x, target.x), (pose.y, target.y)
        rows, cols = grid.world_to_cell(
            [min(xs) - margin, max(xs) + margin], [min(ys) - margin, max(ys) + margin]
        )
        r0, r1 = max(int(rows[0]), 0), min(int(rows[1]) + 1, grid.height)
        c0, c1 = max(int(cols[0]), 0), min(int(cols[1]) + 1, grid.width)
        width = free_width(self.costmap.static_distance[r0:r1, c0:c1], grid.resolution)
        (rs, rg), (cs, cg) = grid.world_to_cell(xs, ys)
        found = widest_way(width, (int(rs) - r0, int(cs) - c0), (int(rg) - r0, int(cg) - c0))
        if found.width <= 0.0:
            return "no free floor joins them in the map"
        x, y = grid.cell_to_world(found.row + r0, found.col + c0)
        high = found.width + grid.resolution  # the measure is at most one cell low
        return (
            f"the widest way there narrows to {found.width:.2f}-{high:.2f} m at ({float(x):.2f},"
            f" {float(y):.2f}), too narrow to plan through for a robot"
            f" {self.config.robot_width:.2f} m wide"
        )

    def _obstacle_field(self, now: float, pose: Pose2D, scan: LaserScan | None) -> ObstacleField:
        half = self.local_planner.field_half_size()
        res = self.grid.resolution
        k = math.ceil(half * math.sqrt(2.0) / res) + 1
        row, col = self.grid.world_to_cell(pose.x, pose.y)
        r0, c0 = int(row) - k, int(col) - k
        window = self.costmap.obstacles_window(now, r0, int(row) + k + 1, c0, int(col) + k + 1)
        pts = obstacle_points_near(
            window,
            max(r0, 0),
            max(c0, 0),
            res,
            self.grid.origin_x,
            self.grid.origin_y,
            pose,
            None if scan is None else scan.points(max_range=2.0 * half),
            self.config.laser_x_offset,
        )
        self._last_obstacle_points = pts
        return self.local_planner.make_field(pts)

    def _rotate_to_goal(self, now: float, pose: Pose2D, target: Pose2D, dt: float) -> NavCommand:
        self._state = NavState.ROTATING
        self._progress_pose, self._progress_time = pose, now
        cfg = self.config
        v = limit_step(0.0, self._command[0], cfg.linear_acceleration * dt, -1e9, 1e9)
        planner = DWAPlanner(cfg.replace(goal_yaw_tolerance=self._yaw_tolerance))
        w, aligned = planner.rotate_to_yaw(pose, target.yaw, self._command[1], dt)
        if aligned:
            self._state = NavState.SUCCEEDED
            self._path = None
            logger.info("goal reached at %s", pose)
            return self._emit(0.0, 0.0, "goal reached")
        return self._emit(v, w, "")

    # -- recoveries ---------------------------------------------------------------------------

    def _reset_recovery(self) -> None:
        self._episode_start = None
        self._episode_pose = None
        self._recovery_step = 0
        self._behaviour = None
        self._stuck_since = None

    def _start_recovery(self, now: float, pose: Pose2D, reason: str) -> NavCommand:
        cfg = self.config
        if self._episode_start is not None and self._left_episode_start(pose):
            self._reset_recovery()  # the last recoveries worked; a new obstacle, a new episode
        if self._episode_start is None:
            self._episode_start, self._episode_pose = now, pose
            self._episode_index = self._index
        if now - self._episode_start >= cfg.blocked_timeout:
            self._state = NavState.BLOCKED
            self._path = None
            self._behaviour = None
            message = (
                f"blocked: {reason}; recoveries made no progress for {cfg.blocked_timeout:g} s"
                f"; {self._where(pose)}"
            )
            logger.warning(message)
            return self._emit(0.0, 0.0, message)
        name = RECOVERY_SEQUENCE[self._recovery_step % len(RECOVERY_SEQUENCE)]
        self._recovery_step += 1
        self._behaviour = _Behaviour(name, now, pose)
        self._state = NavState.RECOVERING
        logger.info("recovery %s (%s)", name, reason)
        self._reason = f"{reason}; recovery: {name}"
        if name == "clear_costmap":
            self.costmap.clear()
            return self._finish_behaviour(now, pose)
        return self._emit(*self._brake(DEFAULT_DT))

    def _left_episode_start(self, pose: Pose2D) -> bool:
        """Whether the robot got away from where this recovery episode began: past a goal since,
        or ``progress_distance`` from there and nearer its goal. The progress checker's window
        restarts after every behaviour, so a robot edging through a doorway while people step
        aside (issue 12, Fetch seed 1: 0.6 m in 36 s, two people in turn) was reported "blocked:
        recoveries made no progress" although they had. Nearer the goal, so that shuttling
        between two stuck places cannot restart the episode for ever."""
        start = self._episode_pose
        if start is None:
            return False
        if self._index > self._episode_index:
            return True
        target = self._goals[self._index]
        moved = pose.distance_to(start) >= self.config.progress_distance
        return moved and pose.distance_to(target) < start.distance_to(target)

    def _where(self, pose: Pose2D) -> str:
        """Where the robot is boxed in and by what (for the blocked message)."""
        target = self._goals[self._index] if self._goals else None
        text = f"at ({pose.x:.2f}, {pose.y:.2f})"
        if target is not None:
            text += f" heading for goal {self._index} ({target.x:.2f}, {target.y:.2f})"
        row, col = self.grid.world_to_cell(pose.x, pose.y)
        if bool(self.grid.in_bounds(row, col)):
            wall = float(self.costmap.static_distance[int(row), int(col)])
            text += f"; the map's nearest wall {wall:.2f} m away"
        pts = self._last_obstacle_points
        if pts is not None and pts.size:
            d = np.hypot(pts[:, 0], pts[:, 1])
            k = int(np.argmin(d))
            bearing = math.degrees(math.atan2(pts[k, 1], pts[k, 0]))
            text += f"; nearest obstacle seen {d[k]:.2f} m from the centre at {bearing:+.0f} deg"
        return text

    def _brake(self, dt: float) -> tuple[float, float]:
        cfg = self.config
        v = limit_step(0.0, self._command[0], cfg.linear_acceleration * dt, -1e9, 1e9)
        w = limit_step(0.0, self._command[1], cfg.angular_acceleration * dt, -1e9, 1e9)
        return v, w

    def _finish_behaviour(self, now: float, pose: Pose2D) -> NavCommand:
        self._behaviour = None
        self._state = NavState.FOLLOWING
        self._path = None
        self._stuck_since = None
        # A fresh progress window, but the recovery episode (and its timeout) continues.
        self._progress_pose, self._progress_time = pose, now
        return self._emit(*self._brake(DEFAULT_DT))

    def _run_recovery(
        self, now: float, pose: Pose2D, scan: LaserScan | None, dt: float
    ) -> NavCommand:
        behaviour = self._behaviour
        if behaviour is None:
            return self._finish_behaviour(now, pose)
        cfg = self.config
        elapsed = now - behaviour.started
        if behaviour.name == "spin":
            field = self._obstacle_field(now, pose, scan)
            turned = abs(pose.yaw - behaviour.start_pose.yaw)
            turned = min(turned, 2 * math.pi - turned) if cfg.spin_angle <= math.pi else turned
            speed = min(0.5, cfg.max_angular_speed)
            limit = cfg.spin_angle / speed + 5.0
            ahead = self.local_planner.footprint_clearance(field, 0.0, 0.0, 0.2)
            if turned >= cfg.spin_angle or elapsed > limit or ahead <= 0.0:
                return self._finish_behaviour(now, pose)
            w = limit_step(speed, self._command[1], cfg.angular_acceleration * dt, -speed, speed)
            v = limit_step(0.0, self._command[0], cfg.linear_acceleration * dt, -1e9, 1e9)
            return self._emit(v, w)
        if behaviour.name == "back_up":
            field = self._obstacle_field(now, pose, scan)
            travelled = pose.distance_to(behaviour.start_pose)
            behind = self.local_planner.footprint_clearance(field, -0.1, 0.0, 0.0)
            limit = cfg.backup_distance / cfg.backup_speed + 3.0
            if travelled >= cfg.backup_distance or elapsed > limit or behind <= 0.0:
                return self._finish_behaviour(now, pose)
            v = limit_step(
                -cfg.backup_speed,
                self._command[0],
                cfg.linear_acceleration * dt,
                -cfg.backup_speed,
                0.0,
            )
            w = limit_step(0.0, self._command[1], cfg.angular_acceleration * dt, -1e9, 1e9)
            return self._emit(v, w)
        # "wait"
        if elapsed >= cfg.wait_duration:
            return self._finish_behaviour(now, pose)
        return self._emit(*self._brake(dt))
