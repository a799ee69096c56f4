"""The robot's control loop: localiser, navigator and velocity multiplexer over one backend.

This is the thesis's Processing Unit (§4.2.3, Fig. 4.5) as one object with time passed in, so
the same code runs in the daemon (monotonic time) and in headless scenarios (simulated time):

* **Localisation.** Odometry at every step is the prior; scans are matched at ``localiser_hz``.
  The localiser works in the laser's frame (its scans are polar about the laser), so the stack
  converts rigidly: ``laser = base ⊕ mount`` and ``base = laser ⊕ mount⁻¹``.
* **Route.** The station sends the whole route (``RouteMsg``); the navigator advances the
  intermediate goals itself, so the robot finishes the route if the station disappears (the
  thesis robot only reached its current intermediate goal).
* **Degraded localisation.** While the localiser reports ``degraded`` (its covariance is large,
  e.g. far along a featureless corridor, or the last scans disagree with the map) the route
  goes on at ``degraded_speed_scale`` of the planner's linear speed. Stopping would not help:
  only motion brings new structure into view to pin the pose again, and bad scans turn
  ``degraded`` into ``lost`` (a stop) within ``LocaliserConfig.lost_after_s``. Slower, the robot
  travels less on odometry alone between scans and people have more time to react. A spell of
  ``degraded`` that lasts is checked (`relocalisation`: a whole-map comparison every second);
  a clearly better place elsewhere means a kidnap, and the robot stops and searches.
* **Suspension.** Autonomous motion is suspended while the robot is not localised (``unset``,
  ``lost`` or ``searching``: a global search is deciding where it is, `relocalisation`), paused (``pause_nav``), e-stopped, or driven by a higher-priority input (shared
  control, thesis §6.3.2). On resumption the navigator replans the remaining goals from where
  the robot is, so no progress timer counts the suspension as being stuck.
* **Multiplexer.** Every step publishes the mux output to the motors: an explicit zero when no
  input is valid or a lock masks them; the emergency stop latches until `release_stop`.
* **One lock for the motion path (issue 14).** The daemon applies teleoperation and stop
  commands from its own command thread while `step` localises and plans on the loop thread.
  ``motion_lock`` guards everything on the way to the motors: the multiplexer, the motion guard
  (collision monitor and assisted teleoperation) and ``backend.set_cmd_vel``. `step` takes it
  only for those short sections, never during the localiser or the planner, so a command
  waits at most for one of them, and every output still passes the collision monitor.
"""

from __future__ import annotations

import logging
import math
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Annotated, Any

import numpy as np
import numpy.typing as npt

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import INTERBOT_LASER_MOUNT, LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.topics import RouteMsg
from interbot_core.velocity_mux import MuxConfig, MuxOutput, VelocityMux, load_mux_config
from robot_daemon.backend import BatteryReading, OdometryReading, RobotBackend
from robot_daemon.config import DEFAULT_MUX, Rates
from robot_daemon.localisation.localiser import (
    Localiser,
    LocaliserConfig,
    LocaliserEstimate,
    LocaliserState,
)
from robot_daemon.localisation.look_around import TURNING_TEXT, LookAround, LookAroundConfig
from robot_daemon.localisation.relocalisation import Relocalisation, RelocalisationConfig
from robot_daemon.planning.config import PlannerConfig, PlannerConfigError
from robot_daemon.planning.goal_checker import final_goal_reached, next_goal_index
from robot_daemon.planning.navigator import Navigator, NavState
from robot_daemon.safety.motion_guard import MotionGuard, MotionGuardConfig, default_guard_config

logger = logging.getLogger(__name__)

PLANNER_TOPIC = "planner_vel"
PAUSE_TOPIC = "pause_nav"
STOP_TOPIC = "stop"
DEFAULT_LASER_MOUNT = INTERBOT_LASER_MOUNT  # [m, m, rad] laser in base_link


class StackError(ValueError):
    """A command the stack cannot accept (the message says why); nothing was changed."""


@dataclass(frozen=True)
class StackConfig:
    """How the stack is put together; every part validates itself."""

    rates: Rates = field(default_factory=Rates)
    mux: MuxConfig = field(default_factory=lambda: load_mux_config(DEFAULT_MUX))
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    localiser: LocaliserConfig = field(default_factory=LocaliserConfig)
    relocalisation: RelocalisationConfig = field(default_factory=RelocalisationConfig)
    look_around: LookAroundConfig = field(default_factory=LookAroundConfig)
    laser_mount: Pose2D = DEFAULT_LASER_MOUNT
    motion_guard: MotionGuardConfig = field(default_factory=default_guard_config)
    degraded_speed_scale: float = 0.5  # planner's linear speed factor while degraded

    def __post_init__(self) -> None:
        scale = Annotated[float, schema.within(0.0, 1.0)]
        schema.checked(self.degraded_speed_scale, scale, "degraded_speed_scale", StackError)


@dataclass
class RouteState:
    """The route the robot is driving, in the station's numbering."""

    msg: RouteMsg  # as the station sent it (ids, nodes, tolerances)
    goals: tuple[Pose2D, ...]
    index: int = 0  # goal the robot is heading for
    state: str = "active"  # active | paused | succeeded | aborted | canceled
    reason: str = ""
    offset: int = 0  # goal index at which the navigator's current (re)plan starts

    @property
    def route_id(self) -> int:
        return self.msg.route_id

    @property
    def finished(self) -> bool:
        return self.state in ("succeeded", "aborted", "canceled")


@dataclass(frozen=True)
class StackEvent:
    """Something worth a line in the station's status log; ``standing``: it stays true once
    said (the station keeps it for operators who connect later: `StandingNotices`)."""

    stamp: float
    level: str  # info | warning | error
    text: str
    standing: bool = False


class Periodic:
    """A periodic deadline on the injected clock."""

    def __init__(self, rate_hz: float) -> None:
        self.period = 1.0 / rate_hz
        self.next = -math.inf

    def __call__(self, now: float) -> bool:
        if now + 1e-9 < self.next:
            return False
        # Keep the phase; skip missed periods instead of bursting to catch up.
        self.next = max(self.next + self.period, now + self.period * 0.5)
        return True


class RobotStack:
    """Localiser + navigator + multiplexer + backend, stepped with ``step(now)``."""

    def __init__(
        self, grid: OccupancyGrid, backend: RobotBackend, config: StackConfig | None = None
    ) -> None:
        self.config = config = config or StackConfig()
        self.grid = grid
        self.backend = backend
        self.mux = VelocityMux(config.mux)
        # The multiplexer, the motion guard and the motors' input, shared with the daemon's
        # command thread (module docstring). Re-entrant: `apply_output` runs inside `step`'s.
        self.motion_lock = threading.RLock()
        planner = config.planner
        if planner.laser_x_offset != config.laser_mount.x:
            planner = planner.replace(laser_x_offset=config.laser_mount.x)
        self.navigator = Navigator(grid, planner)
        self.localiser = Localiser(grid, config.localiser)
        # Collision monitor under the mux, assisted teleop before it (robot_daemon/safety).
        self.guard = MotionGuard(config.motion_guard, config.laser_mount)
        self.relocalisation = Relocalisation(grid, self.localiser, config.relocalisation)
        self.look_around = LookAround(config.look_around)
        self._mount = config.laser_mount
        self._mount_inv = config.laser_mount.inverse()
        self._localise_due = Periodic(config.rates.localiser_hz)
        self._control_due = Periodic(config.rates.controller_hz)
        self.route: RouteState | None = None
        self.suspended_reason: str | None = None
        self.last_odometry: OdometryReading | None = None
        self.last_scan: LaserScan | None = None
        self._scan_localised: LaserScan | None = None
        self.last_estimate: LocaliserEstimate | None = None
        self.last_output = MuxOutput(0.0, 0.0, None, "not started")
        self.last_battery: BatteryReading | None = None
        self.last_jpeg: bytes | None = None
        self._events: deque[StackEvent] = deque(maxlen=200)
        self._localisation_state = LocaliserState.UNSET
        self._wall_model_told = False  # the learnt wall model is told to the station once
        self.last_scan_time = 0.0  # [s] of the last localised scan
        for name in ("station_vel", "tablet_vel", PLANNER_TOPIC):
            config.mux.input_by_topic(name)  # raises if the mux config lacks an input we need
        for name in (PAUSE_TOPIC, STOP_TOPIC):
            config.mux.lock_by_topic(name)

    # -- events ----------------------------------------------------------------------------

    def _event(self, now: float, level: str, text: str, standing: bool = False) -> None:
        log = {"info": logger.info, "warning": logger.warning, "error": logger.error}[level]
        log("%s", text)
        self._events.append(StackEvent(now, level, text, standing))

    def drain_events(self) -> list[StackEvent]:
        """Status-log lines since the last call.

        Popped one by one: the daemon's command thread may add one meanwhile (an e-stop), and
        a copy-then-clear would lose it."""
        events: list[StackEvent] = []
        while self._events:
            events.append(self._events.popleft())
        return events

    # -- commands (from the link or a scenario script) --------------------------------------

    def on_twist(self, topic: str, linear: float, angular: float, now: float) -> None:
        """A teleoperation command on ``station_vel`` or ``tablet_vel``."""
        if topic == PLANNER_TOPIC:
            raise StackError("planner_vel is the robot's own planner; it is not a command input")
        with self.motion_lock:
            linear, angular = self.guard.on_teleop(topic, linear, angular, now)
            self.mux.on_twist(topic, linear, angular, now)

    def set_teleop_assist(self, topic: str, enabled: bool, now: float) -> None:
        """Assisted teleoperation on or off for ``station_vel`` / ``tablet_vel``."""
        if topic not in ("station_vel", "tablet_vel"):
            raise StackError(
                f"assisted teleoperation applies to station_vel or tablet_vel, not {topic!r}"
            )
        with self.motion_lock:
            changed = self.guard.set_assist(topic, enabled)
        if changed:
            self._event(
                now, "info", f"assisted teleoperation {'on' if enabled else 'off'} for {topic}"
            )

    def on_lock(self, topic: str, engaged: bool, now: float) -> None:
        """``pause_nav`` or ``stop``; the stop lock latches until `release_stop`."""
        with self.motion_lock:
            self.mux.on_lock(topic, engaged, now)
        if topic == STOP_TOPIC and engaged:
            self._event(now, "warning", "emergency stop engaged (latched until released)")
        elif topic == PAUSE_TOPIC:
            self._event(now, "info", "navigation paused" if engaged else "navigation resumed")

    def release_stop(self, now: float, operator: str = "") -> None:
        with self.motion_lock:
            released = self.mux.release_stop()
        if released:
            who = f" by {operator}" if operator else ""
            self._event(now, "info", f"emergency stop released{who}")

    def set_initial_pose(self, pose: Pose2D, now: float, verify: bool = False) -> None:
        """The station's (or tablet's "Help me!") initial pose of base_link in ``map``;
        with ``verify`` it is only a hint: the global search around it must confirm it."""
        if not self.grid.is_free(pose.x, pose.y):
            raise StackError(
                f"initial pose ({pose.x:.2f}, {pose.y:.2f}) is not in free space of {self.grid.source}"
            )
        if verify:
            event = self.relocalisation.verify_help(pose.compose(self._mount), now)
            self._event(now, event.level, event.text)
            return
        self.relocalisation.cancel()
        self.localiser.set_initial_pose(pose.compose(self._mount), now)
        self._event(
            now, "info", f"initial pose set to ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})"
        )

    def relocalise(self, now: float) -> None:
        """The station's "Relocalise": search the whole map (autonomy waits meanwhile)."""
        event = self.relocalisation.request(now)
        self._event(now, event.level, event.text)

    def set_route(self, msg: RouteMsg, now: float) -> None:
        """Drive the whole route; replaces any route in progress."""
        goals = tuple(Pose2D(x, y, yaw) for x, y, yaw in msg.waypoints)
        if not self.grid.is_free(goals[-1].x, goals[-1].y):
            raise StackError(
                f"route {msg.route_id}: goal ({goals[-1].x:.2f}, {goals[-1].y:.2f}) "
                f"is not in free space of {self.grid.source}"
            )
        self.route = RouteState(msg, goals)
        self.suspended_reason = "new route"
        self.navigator.cancel()
        self._event(now, "info", f"route {msg.route_id}: {len(goals)} goal(s)")

    def cancel_route(self, now: float, reason: str = "cancelled") -> None:
        if self.route is not None and not self.route.finished:
            self.route.state, self.route.reason = "canceled", reason
            self._event(now, "info", f"route {self.route.route_id} {reason}")
        self.navigator.cancel()
        self.suspended_reason = None

    def abort_route(self, now: float, reason: str) -> None:
        """Give up the route in progress and zero the planner's input (an internal error)."""
        with self.motion_lock:
            self.mux.on_twist(PLANNER_TOPIC, 0.0, 0.0, now)
        if self.route is not None and not self.route.finished:
            self.route.state, self.route.reason = "aborted", reason
            self._event(now, "error", f"route {self.route.route_id} aborted: {reason}")
        self.navigator.cancel()
        self.suspended_reason = None

    def reconfigure(self, params: dict[str, Any], now: float) -> None:
        """Planner parameters on the fly (names of `PlannerConfig` fields); all or nothing."""
        try:
            self.navigator.reconfigure(**params)
        except PlannerConfigError as exc:
            raise StackError(str(exc)) from None
        self.suspended_reason = self.suspended_reason or "reconfigured"
        self._event(now, "info", f"planner reconfigured: {params}")

    # -- state -------------------------------------------------------------------------------

    @property
    def pose(self) -> Pose2D | None:
        """base_link in the building now, the pose the robot reports (the station, the tablet,
        the figures): the last estimate moved by odometry since, the map's own offset there
        taken out (`Localiser.building_pose`, `map_offset`; the map pose until the filter has
        learnt its odometry's walk, or with it off; None if unset)."""
        laser = self.localiser.current_building_pose
        return None if laser is None else laser.compose(self._mount_inv)

    @property
    def map_pose(self) -> Pose2D | None:
        """base_link *on the map* now: where the map's walls are relative to the robot, the pose
        navigation acts on (the planner plans among the map's walls, a door is where the scans
        put it; the route's stops are the map's). Differs from `pose` by the map's offset
        (a few centimetres)."""
        laser = self.localiser.current_pose
        return None if laser is None else laser.compose(self._mount_inv)

    @property
    def localisation_state(self) -> LocaliserState:
        """The localiser's state, ``searching`` while a global search runs (issue 16)."""
        return self.relocalisation.state(self.localiser.state, self.last_scan_time)

    @property
    def reported_localisation(self) -> str:
        """The state the station and tablet are told (`interbot_core.topics.POSE_STATES`):
        the localisation state, and ``turning`` while a search turns the robot in place
        (`look_around`), so a person sees why it rotates."""
        state = self.localisation_state
        if state is LocaliserState.SEARCHING and self.look_around.turning:
            return "turning"
        return state.value

    @property
    def pose_covariance(self) -> npt.NDArray[np.float64]:
        """3x3 covariance of `pose` (base_link x, y, yaw in the building), from the localiser's
        laser-pose covariance (`Localiser.building_covariance`) through ``base = laser ⊕
        mount⁻¹``; zeros while unset."""
        laser = self.localiser.current_building_pose
        cov = self.localiser.building_covariance
        if laser is None:
            return cov
        c, s = math.cos(laser.yaw), math.sin(laser.yaw)
        m = self._mount_inv
        jac = np.array(
            [[1.0, 0.0, -s * m.x - c * m.y], [0.0, 1.0, c * m.x - s * m.y], [0.0, 0.0, 1.0]]
        )
        out: npt.NDArray[np.float64] = jac @ cov @ jac.T
        return out

    # -- the loop ------------------------------------------------------------------------------

    def step(self, now: float) -> MuxOutput:
        """One pass of the control loop at time ``now`` [s]; returns what went to the motors."""
        odom = self.backend.read_odometry(now)
        if odom is not None:
            self.last_odometry = odom
            laser_odometry = odom.pose.compose(self._mount)
            self.localiser.on_odometry(laser_odometry, now)
            self.relocalisation.on_odometry(laser_odometry)
        scan = self.backend.read_scan(now)
        if scan is not None:
            self.last_scan = scan
            with self.motion_lock:
                self.guard.on_scan(scan, now)
        if (
            self.last_scan is not None
            and self.last_scan is not self._scan_localised
            and self._localise_due(now)
        ):
            self._scan_localised = self.last_scan
            self.last_estimate = self.localiser.on_scan(self.last_scan, now)
            self._relocalise(now)
            self._track_localisation(now)
            self._track_wall_model(now)
        if self._control_due(now):
            self._look_around(now)
            self._control(now)
        output = self.apply_output(now)
        battery = self.backend.read_battery(now)
        if battery is not None:
            self.last_battery = battery
        jpeg = self.backend.read_camera_jpeg(now)
        if jpeg is not None:
            self.last_jpeg = jpeg
        return output

    def apply_output(self, now: float) -> MuxOutput:
        """Send the multiplexer's current output to the motors (also between loop passes, from
        the daemon's command thread)."""
        with self.motion_lock:
            output = self.guard.limit(self.mux.output(now), now)  # the collision monitor
            self.backend.set_cmd_vel(output.linear, output.angular, now)
            self.last_output = output
            return output

    def _relocalise(self, now: float) -> None:
        self.last_scan_time = now
        speed = self.last_odometry.linear if self.last_odometry is not None else 0.0
        laser, events = self.relocalisation.step(self.last_scan, speed, now)
        for event in events:
            self._event(now, event.level, event.text)
        if laser is not None:
            self.localiser.set_initial_pose(laser, now)
            base = laser.compose(self._mount_inv)
            self._event(
                now, "info", f"initial pose set to ({base.x:.2f}, {base.y:.2f}, {base.yaw:.2f})"
            )

    def _track_localisation(self, now: float) -> None:
        state = self.localisation_state
        if state != self._localisation_state:
            level = {LocaliserState.LOST: "error", LocaliserState.DEGRADED: "warning"}.get(
                state, "info"
            )
            text = f"localisation {state.value}"
            if state is LocaliserState.DEGRADED and self.last_estimate is not None:
                text += f": {self.last_estimate.reason}"
            self._event(now, level, text)
            self._localisation_state = state
            if state in (LocaliserState.LOST, LocaliserState.SEARCHING):
                # Stop now: do not drive blind on the planner's last command until it times out.
                with self.motion_lock:
                    self.mux.on_twist(PLANNER_TOPIC, 0.0, 0.0, now)

    def _track_wall_model(self, now: float) -> None:
        """Once the localiser has learnt where its map's walls lie, say so on the status log
        (the station shows it): a model that moves every wall by half a cell is the
        operator's to know, not only the robot's log's."""
        if self._wall_model_told:
            return
        status = self.localiser.wall_model
        notice = status.notice()
        if notice is not None:
            self._event(now, "info", notice, standing=True)
        # Told, or fixed by configuration (nothing to tell): not looked at again on the scan path.
        self._wall_model_told = notice is not None or not status.learning

    def _look_around(self, now: float) -> None:
        """While a global search is undecided, turn in place to see more (`look_around`):
        on the planner's input, so locks, operators and the collision monitor rule it. Not
        while checking a "Help me!" pose: the person who gave it stands at the tablet.

        Only in the service of a command (no motion nobody commanded): the operator's
        "Relocalise", or a route the robot was given and cannot drive while it does not know
        where it is. A robot switched on, or pushed, while idle searches standing still.
        """
        reloc = self.relocalisation
        reason = reloc.relocaliser.reason
        route_waiting = self.route is not None and not self.route.finished
        commanded = reason == "request" or (route_waiting and reason != "help-me")
        searching = reloc.active and commanded
        since = reloc.relocaliser.since if searching else None
        yaw = self.last_odometry.pose.yaw if self.last_odometry is not None else None
        was_turning = self.look_around.turning
        if searching and not was_turning and reloc.relocaliser.ripening:
            # A place is being confirmed standing: turning now would make every other place
            # block it (`Relocaliser._decide`); turn only if it does not settle.
            return
        angular = self.look_around.update(since, yaw, self._motion_blocker(now), now)
        reloc.relocaliser.turning = angular is not None
        if angular is not None:
            if not was_turning:
                self._event(now, "info", TURNING_TEXT)
            with self.motion_lock:
                self.mux.on_twist(PLANNER_TOPIC, 0.0, angular, now)
        elif was_turning:
            with self.motion_lock:
                self.mux.on_twist(PLANNER_TOPIC, 0.0, 0.0, now)  # stop turning at once
            reason = self.look_around.end_reason
            if reason:
                level = "warning" if self.look_around.stalled else "info"
                self._event(now, level, f"stopped turning ({reason})")

    def _autonomy_blocker(self, now: float) -> str | None:
        """Why the planner may not drive now, or None."""
        state = self.localisation_state
        if state not in (LocaliserState.OK, LocaliserState.DEGRADED):
            return f"localisation {state.value}"
        return self._motion_blocker(now)

    def _motion_blocker(self, now: float) -> str | None:
        """Why the robot may not move by itself now (locks, an operator driving), or None."""
        with self.motion_lock:
            locks = {lock.topic for lock in self.mux.active_locks(now)}
            valid = self.mux.valid_inputs(now)
        if STOP_TOPIC in locks:
            return "emergency stop"
        if PAUSE_TOPIC in locks:
            return "paused"
        planner_priority = self.config.mux.input_by_topic(PLANNER_TOPIC).priority
        for entry in valid:
            if entry.priority > planner_priority:
                return f"manual control ({entry.name})"
        return None

    def _judge_progress(self, route: RouteState, pose: Pose2D | None, now: float) -> None:
        """While the route is suspended and someone else drives (an operator), judge its progress
        all the same (`goal_checker`): the station mirrors what the robot reports and has no goal
        logic of its own. Not on a pose the localiser does not vouch for."""
        if pose is None or self.localisation_state not in (
            LocaliserState.OK,
            LocaliserState.DEGRADED,
        ):
            return
        msg = route.msg
        route.index = next_goal_index(route.goals, route.index, pose, msg.approach_tolerance)
        final = route.goals[-1]
        if route.index == len(route.goals) - 1 and final_goal_reached(
            pose, final, msg.goal_tolerance, msg.yaw_tolerance
        ):
            route.state, route.reason = "succeeded", "goal reached"
            self.suspended_reason = None
            self._event(now, "info", f"route {route.route_id} done: goal reached")

    def _control(self, now: float) -> None:
        route = self.route
        if route is None or route.finished:
            return
        blocker = self._autonomy_blocker(now)
        pose = self.map_pose  # navigation plans on the map
        if blocker is not None or pose is None:
            if self.suspended_reason is None:
                self.navigator.cancel()
                self._event(now, "info", f"route {route.route_id} suspended: {blocker}")
            self.suspended_reason = blocker or "no pose"
            route.state = "paused"
            self._judge_progress(route, pose, now)
            return
        if self.suspended_reason is not None:
            remaining = route.goals[route.index :]
            self.navigator.set_route(
                remaining,
                approach_tolerance=route.msg.approach_tolerance,
                goal_xy_tol=route.msg.goal_tolerance,
                goal_yaw_tol=route.msg.yaw_tolerance,
                now=now,
            )
            route.offset = route.index
            route.state = "active"
            self.suspended_reason = None
        command = self.navigator.update(now, pose, self.last_scan)
        route.index = min(route.offset + command.goal_index, len(route.goals) - 1)
        if command.state == NavState.SUCCEEDED:
            route.index = len(route.goals) - 1
            route.state, route.reason = "succeeded", "goal reached"
            self._event(now, "info", f"route {route.route_id} done: goal reached")
        elif command.state == NavState.BLOCKED:
            route.state, route.reason = "aborted", command.reason or "blocked"
            self._event(now, "error", f"route {route.route_id} blocked: {route.reason}")
        linear = command.linear
        if self.localiser.state is LocaliserState.DEGRADED:
            linear *= self.config.degraded_speed_scale
        with self.motion_lock:
            self.mux.on_twist(PLANNER_TOPIC, linear, command.angular, now)
