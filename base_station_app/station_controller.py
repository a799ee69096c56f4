"""The Base Station's controller: ``clock()`` and everything the operator and the tablet command.

Thesis §5.3 and §5.3.6 (Fig. 5.12): after start-up (TCP server listening, timers started, the
robot link open, the topological map loaded and every route precomputed) a `QTimer` calls
``clock()`` every 100 ms (``Qt.PreciseTimer``), which has three sections:

* **speed** - publish the station's teleoperation command on ``station_vel`` while a key, pad
  button or the mouse joystick is held; forward the tablet's joystick command on ``tablet_vel``
  if the tablet may teleoperate and the latency watchdog (§5.3.4) has not expired;
* **pose** - feed the robot's pose to the `Supervisor` (Algorithm 5 routes, tour stops,
  requests) and act on its events: send the whole route, cancel it, pause at tour stops;
* **communication** - send the tablet ``initial_pose: false`` until the robot is localised, then
  its ``pose``, the current ``goal`` with the ``reached`` / ``tourReached`` flags, the tour
  state, requests to show and status text (§5.3.2, §5.3.6).

A second, 25 ms frame timer pulls the newest robot state from the zenoh link (a ring of one per
topic) into `RobotState` and emits ``frame_ready``; views redraw from it, never per message.
Time comes from an injectable ``clock`` (``time.monotonic`` by default) so tests control it.
This object holds no widgets; the main window wires widgets to its signals and slots.
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh
from PySide6.QtCore import QObject, Qt, QTimer, Signal

from base_station_app.map_rooms import RoomArea, load_room_areas
from base_station_app.robot_state import RobotState
from base_station_app.station_config import StationConfig
from base_station_app.tablet_auth import TabletAuthServer
from base_station_app.tablet_server import TabletServer
from base_station_app.tablet_session import TabletPermissions, describe_task, permission_for
from base_station_app.teleop import Direction, TeleopInput
from interbot_core import protocol as p
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import MapLoadError, OccupancyGrid, load_map
from interbot_core.route_follower import ROBOT_TOLERANCE_SHARE
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import (
    Delivery,
    Event,
    GoalReached,
    GoHome,
    GoTo,
    GuidedTour,
    IntermediateGoalReached,
    PauseNavigation,
    QueueChanged,
    RequestAccepted,
    RequestDeclined,
    RequestShown,
    RequestTimedOut,
    RouteCancelled,
    RouteStarted,
    Supervisor,
    SupervisorError,
    SupervisorState,
    Task,
    TaskFinished,
    TaskRejectedError,
    TaskStarted,
    TourStopReached,
)
from interbot_core.topics import (
    AssistMsg,
    ConfigMsg,
    InitialPose,
    Lock,
    RouteCancel,
    RouteMsg,
    RouteProgress,
    StopRelease,
    Topic,
    Twist,
)
from interbot_core.topological_map import TopologicalMap
from interbot_core.watchdog import LatencyWatchdog, PeriodStats
from interbot_link import LinkError, RobotAppeared, RobotLeft, StateMessage, StationLink

logger = logging.getLogger(__name__)

Clock = Callable[[], float]

#: [s] after an initial pose is sent, the robot's "unset"/"lost" is not passed on to the tablet
#: (the localiser applies the pose at its next scan, well within this at 10-40 Hz).
INITIAL_POSE_SETTLE_S = 2.0


@dataclass(frozen=True)
class Timing:
    """Timer intervals [ms]; tests shorten them."""

    clock_ms: int = 100  # thesis §6.4: commands every 100 ms
    frame_ms: int = 25  # view refresh (40 Hz, the laser's rate)
    ping_ms: int = 1000  # tablet latency probe


class StationController(QObject):
    """State, commands and the control loop of the Base Station (see the module docstring)."""

    frame_ready = Signal()
    clocked = Signal()
    robots_changed = Signal()
    robot_selected = Signal(str)
    tasks_changed = Signal()
    log_added = Signal(str, str)  # level, text
    estop_changed = Signal(bool)
    paused_changed = Signal(bool)
    tablet_changed = Signal()
    latency_added = Signal(float)  # round trip [s]
    config_changed = Signal(object)
    tour_stop_reached = Signal(object)  # TourStopReached
    request_shown = Signal(object)  # RequestShown
    route_sent = Signal(object)  # RouteMsg
    assist_changed = Signal(bool)  # the station's assisted teleoperation

    def __init__(
        self,
        topo: TopologicalMap,
        session: zenoh.Session | None,
        *,
        topo_path: str | Path | None = None,
        clock: Clock = time.monotonic,
        config: StationConfig | None = None,
        tablet_host: str = "127.0.0.1",
        tablet_port: int = 5555,
        robot_id: str | None = None,
        timing: Timing = Timing(),
        tablet_auth: TabletAuthServer | None = None,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self.tablet_auth = tablet_auth  # TLS + pairing (issue 15); None: plaintext thesis tablet
        self.clock = clock
        self.topo = topo
        self.names = {n.id: n.name for n in topo.nodes}
        self.planner = RoutePlanner(topo)  # Floyd-Warshall: every route precomputed (§5.3.3)
        self.config = config if config is not None else StationConfig()
        self.supervisor = Supervisor(topo, self.planner, self.config.supervisor_config())
        self.rooms: list[RoomArea] = (
            load_room_areas(topo_path, topo) if topo_path is not None else []
        )
        self.static_map = self._load_static_map()
        self.state = RobotState()
        self.teleop = TeleopInput(self.config.teleop_linear_max, self.config.teleop_angular_max)
        self.watchdog = LatencyWatchdog(self.config.latency_ceiling)
        self.clock_periods = PeriodStats(5000)
        self.tablet_periods = PeriodStats(5000)
        self.latencies: deque[float] = deque(maxlen=300)
        self.permissions = TabletPermissions()
        self.preferred_robot = robot_id
        self.robots: dict[str, bool] = {}  # robot id -> present
        self.estop_latched = False
        self.route: RouteMsg | None = None
        self.route_index = 0
        self.tablet_speed: p.Speed | None = None
        self.tablet_forwarding = False
        self.tablet_discarded = 0
        self.tablet_tasks: list[Task] = []  # tasks the tablet ordered (identity matters)
        self.request_id = 0
        self.shown_request: tuple[int, RequestShown] | None = None
        self.goal_reached = False
        self._route_id = 0
        self._verdict_of: int | None = None  # route whose end the robot reported, if handled
        self._last_clock: float | None = None
        self._tour_state_sent: p.TourState | None = None
        self._status_sent: p.StatusInfo | None = None
        self._localisation_sent: str | None = None
        self._safety_sent: p.SafetyInfo | None = None
        self._pose_settling_until = -math.inf  # see INITIAL_POSE_SETTLE_S
        self._teleop_was_active = False
        self._config_pending = True  # (re)send the planner config until a robot receives it
        self._route_pending = False  # (re)send the route until a robot receives it
        self.station_assist = False  # assisted teleoperation of station_vel (issue 17)
        self._assist_pending = True  # (re)send it until a robot receives it
        self._closed = False

        self.link: StationLink | None = StationLink(session) if session is not None else None
        self.tablet = TabletServer(
            clock,
            tablet_host,
            tablet_port,
            robot_name=lambda: self.selected_robot or "none",
            limits=p.ProtocolLimits(node_ids=frozenset(self.names)),
            ping_interval_ms=timing.ping_ms,
            server=tablet_auth,
            parent=self,
        )
        self.tablet.connected.connect(self._on_tablet_connected)
        self.tablet.disconnected.connect(self._on_tablet_disconnected)
        self.tablet.message_received.connect(self.on_tablet_message)
        self.tablet.latency_measured.connect(self._on_latency)
        self.tablet.protocol_error.connect(lambda text: self.log("warning", f"tablet: {text}"))
        self.tablet.refused.connect(
            lambda peer, why: self.log("warning", f"refused tablet {peer}: {why}")
        )

        self.clock_timer = QTimer(self)
        self.clock_timer.setTimerType(Qt.TimerType.PreciseTimer)
        self.clock_timer.setInterval(timing.clock_ms)
        self.clock_timer.timeout.connect(self.tick)
        self.frame_timer = QTimer(self)
        self.frame_timer.setInterval(timing.frame_ms)
        self.frame_timer.timeout.connect(self.poll_link)

    # ================================================================== lifetime
    def start(self, timers: bool = True) -> bool:
        """Listen for the tablet and start the timers; False if the tablet port is taken.

        ``timers=False`` leaves ``tick`` / ``poll_link`` to the caller (tests step them).
        """
        ok = self.tablet.listen()
        if not ok:
            self.log("error", f"cannot listen for the tablet on port {self.tablet.port}")
        if timers:
            self.clock_timer.start()
            self.frame_timer.start()
        self.log("info", f"station started; {len(self.topo)} nodes, routes precomputed")
        return ok

    def shutdown(self) -> None:
        """Stop timers, stop the robot if teleoperated, close the tablet and the link (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self.clock_timer.stop()
        self.frame_timer.stop()
        if self.teleop.active:
            self.teleop.release_all()
            self._send(Topic.STATION_VEL, Twist(0.0, 0.0, stamp=self.clock()))
        self.tablet.close()
        if self.link is not None:
            self.link.close()
        logger.info("station controller shut down")

    def _load_static_map(self) -> OccupancyGrid | None:
        if self.topo.map_yaml_path is None:
            return None
        try:
            return load_map(self.topo.map_yaml_path)
        except MapLoadError as exc:
            logger.warning("no static map: %s", exc)
            return None

    @property
    def grid(self) -> OccupancyGrid | None:
        """The robot's map when received, else the map beside the topological map."""
        return self.state.grid if self.state.grid is not None else self.static_map

    def log(self, level: str, text: str) -> None:
        self.state.add_log(self.clock(), level, text)
        self.log_added.emit(level, text)

    # ================================================================== robot link
    def _send(self, topic: Topic, message: object) -> bool:
        if self.link is None or self.link.selected is None or self._closed:
            return False
        try:
            return self.link.send(topic, message)
        except LinkError as exc:
            self.log("error", f"cannot send {topic}: {exc}")
            return False

    def select_robot(self, robot_id: str | None) -> None:
        if self.link is None:
            return
        if robot_id == self.link.selected:
            return
        self.state.clear()
        self.link.select_robot(robot_id)
        self.log("info", f"commanding robot {robot_id}" if robot_id else "no robot selected")
        self.robot_selected.emit(robot_id or "")
        self._config_pending = True
        self._assist_pending = True
        self._route_pending = self.route is not None
        self._resend_pending()

    def _resend_pending(self) -> None:
        """Must-arrive state that found no subscriber (robot not yet linked, or restarted)."""
        if self._config_pending:
            self._config_pending = not self._send(
                Topic.CONFIG, ConfigMsg(self.config.planner_params())
            )
        if self._route_pending and self.route is not None:
            self._route_pending = not self._send(Topic.ROUTE, self.route)
        if self._assist_pending:
            msg = AssistMsg("station_vel", self.station_assist, stamp=self.clock())
            self._assist_pending = not self._send(Topic.TELEOP_ASSIST, msg)

    def set_station_assist(self, enabled: bool) -> None:
        """Assisted teleoperation on/off for the station's own driving (the robot applies it)."""
        if enabled == self.station_assist:
            return
        self.station_assist = enabled
        self._assist_pending = True
        self._resend_pending()
        self.log("info", f"assisted driving {'on' if enabled else 'off'} for the Base Station")
        self.assist_changed.emit(enabled)

    @property
    def selected_robot(self) -> str | None:
        return None if self.link is None else self.link.selected

    def poll_link(self) -> None:
        """Frame timer (25 ms): pull link events and the newest state, then ``frame_ready``."""
        link = self.link
        if link is not None:
            for event in link.poll_events():
                self._on_link_event(event)
            for topic, message in link.poll_state().items():
                self.state.apply(topic, message)
            progress, route = self.state.progress, self.route
            if progress is not None and route is not None and progress.route_id == route.route_id:
                self.route_index = progress.index
                self._robot_verdict(progress)
        self.frame_ready.emit()

    def _robot_verdict(self, progress: RouteProgress) -> None:
        """The robot finished or gave up the current route: its word settles the task."""
        if progress.state not in ("succeeded", "aborted") or progress.route_id == self._verdict_of:
            return
        self._verdict_of = progress.route_id
        if progress.state == "succeeded":
            self._handle(self.supervisor.robot_route_succeeded(self.clock()))
        else:
            self.log("error", f"robot gave up route {progress.route_id}: {progress.reason}")
            self._handle(self.supervisor.robot_route_aborted(progress.reason))

    def _on_link_event(self, event: object) -> None:
        if isinstance(event, RobotAppeared):
            self.robots[event.robot_id] = True
            self.log("info", f"robot {event.robot_id} is online")
            self.robots_changed.emit()
            selected = self.selected_robot
            if selected == event.robot_id and self.link is not None:
                self.link.request_state()  # it came back (restart?): map, config and route again
                self._config_pending = True
                self._route_pending = self.route is not None
            elif selected is None and self.preferred_robot in (None, event.robot_id):
                self.select_robot(event.robot_id)
        elif isinstance(event, RobotLeft):
            self.robots[event.robot_id] = False
            self.log("error", f"robot {event.robot_id} lost (liveliness token gone)")
            self.robots_changed.emit()
        elif isinstance(event, StateMessage):
            self.state.apply(event.topic, event.message)
            if event.topic is Topic.STATUS:
                status = self.state.status
                if status is not None and status.text:
                    self.log(status.level, f"robot: {status.text}")

    # ================================================================== clock()
    def tick(self) -> None:
        """The control loop (thesis Fig. 5.12): speed, pose, communication."""
        now = self.clock()
        if self._last_clock is not None:
            self.clock_periods.add_period(max(0.0, now - self._last_clock))
        self._last_clock = now
        self._resend_pending()
        self._speed_section(now)
        self._pose_section(now)
        self._communication_section(now)
        self.clocked.emit()

    def _speed_section(self, now: float) -> None:
        if self.teleop.active:
            linear, angular = self.teleop.command()
            self._send(Topic.STATION_VEL, Twist(linear, angular, stamp=now))
        speed = self.tablet_speed
        if speed is None:
            return
        if self.permissions.teleop and not self.watchdog.expired(now):
            self._send(Topic.TABLET_VEL, Twist(speed.linear, speed.angular, stamp=now))
            self.tablet_forwarding = True
            return
        # Watchdog expired (or permission revoked): discard the tablet's command (§5.3.4).
        self.tablet_speed = None
        self.tablet_discarded += 1
        if self.tablet_forwarding:
            self._send(Topic.TABLET_VEL, Twist(0.0, 0.0, stamp=now))
            self.tablet_forwarding = False
        why = "not permitted" if not self.permissions.teleop else "latency above the ceiling"
        self.log("warning", f"tablet speed command discarded ({why})")

    def _pose_section(self, now: float) -> None:
        events = self.supervisor.update(now, self.state.localised_pose)
        self._handle(events)

    def _communication_section(self, now: float) -> None:
        if not self.tablet.is_connected:
            return
        send = self.tablet.send
        pose = self.state.localised_pose
        loc = self.state.localisation
        settling = loc in ("unset", "lost") and now < self._pose_settling_until
        if loc != self._localisation_sent and not settling:
            send(p.Localisation(loc))
            self._localisation_sent = loc
        safety = self.state.safety
        if safety is not None:  # the collision monitor, for the person at the joystick
            info = p.SafetyInfo(
                safety.zone, round(safety.distance, 2), "tablet_vel" in safety.assisted
            )
            if info != self._safety_sent:
                send(info)
                self._safety_sent = info
        if self.state.pose is None or self.state.pose.state == "unset":
            if not settling:
                send(p.InitialPose(False))
        elif pose is not None:
            send(p.Pose(pose.x, pose.y, pose.yaw))
        goal = self.supervisor.current_goal_node
        at_stop = self.supervisor.state is SupervisorState.AT_TOUR_STOP
        if goal is not None:
            send(p.GoalStatus(goal, self.goal_reached, at_stop))
        tour = self._tour_state()
        if tour != self._tour_state_sent:  # an ended tour is said too: no stale highlight
            send(tour if tour is not None else p.TourState((), (), None))
        self._tour_state_sent = tour
        status = p.StatusInfo(self.task_text(), self.status_text())
        if status != self._status_sent:
            send(status)
            self._status_sent = status

    def _tour_state(self) -> p.TourState | None:
        stops = self.supervisor.tour_stops
        if not stops:
            return None
        return p.TourState(
            stops, self.supervisor.visited_tour_stops, self.supervisor.next_tour_stop
        )

    def task_text(self) -> str:
        task = self.supervisor.current_task
        return "idle" if task is None else describe_task(task, self.names)

    def status_text(self) -> str:
        sup = self.supervisor
        if self.estop_latched:
            return "emergency stop engaged"
        text = str(sup.state).replace("_", " ")
        d = sup.distance_to_next_goal
        if d is not None:
            text += f", {d:.1f} m to the next goal"
        return text

    # ================================================================== supervisor events
    def _handle(self, events: list[Event]) -> None:
        for event in events:
            self._handle_one(event)

    def _handle_one(self, event: Event) -> None:
        if isinstance(event, TaskStarted):
            self.goal_reached = False
            self.log("info", f"task started: {describe_task(event.task, self.names)}")
            self.tasks_changed.emit()
        elif isinstance(event, TaskFinished):
            level = "info" if event.ok else "warning"
            self.log(level, f"task {describe_task(event.task, self.names)}: {event.reason}")
            if self._is_tablet_task(event.task):
                self.tablet_tasks = [t for t in self.tablet_tasks if t is not event.task]
            self.shown_request = None
            self.tasks_changed.emit()
        elif isinstance(event, QueueChanged):
            self.tasks_changed.emit()
        elif isinstance(event, RouteStarted):
            self._send_route(event)
        elif isinstance(event, RouteCancelled):
            self._cancel_route(event.reason)
        elif isinstance(event, IntermediateGoalReached):
            self.log("info", f"intermediate goal {event.node} reached")
        elif isinstance(event, GoalReached):
            self.goal_reached = True
            where = self.names.get(event.node, "pose") if event.node is not None else "pose"
            self.log("info", f"goal reached: {where}")
            if event.node is not None:
                self.tablet.send(p.GoalStatus(event.node, True, False))
        elif isinstance(event, PauseNavigation):
            self._send(Topic.PAUSE_NAV, Lock(event.paused, stamp=self.clock()))
            self.log("info", "navigation paused" if event.paused else "navigation resumed")
            self.paused_changed.emit(event.paused)
        elif isinstance(event, TourStopReached):
            self.goal_reached = True
            self._handle(self.supervisor.pause())  # wait at the stop until resumed (§5.3.6)
            self.log("info", f"tour stop {event.node} ({event.name}) reached; tour paused")
            self.tablet.send(p.GoalStatus(event.node, True, True))
            self.tour_stop_reached.emit(event)
        elif isinstance(event, RequestShown):
            self.request_id += 1
            self.shown_request = (self.request_id, event)
            self.tablet.send(
                p.ShowRequest(self.request_id, event.text, event.room, event.deliver_to)
            )
            self.log("info", f"request shown at {self.names[event.room]}: {event.text}")
            self.request_shown.emit(event)
        elif isinstance(event, RequestAccepted | RequestDeclined | RequestTimedOut):
            verb = {RequestAccepted: "accepted", RequestDeclined: "declined"}.get(
                type(event), "timed out"
            )
            self.shown_request = None
            self.log("info", f"request '{event.text}' {verb}")

    def _send_route(self, route: RouteStarted) -> None:
        self._route_id += 1
        ids = route.node_ids
        node_ids = tuple(n for n in ids if n is not None) if None not in ids else ()
        cfg = self.config
        msg = RouteMsg(
            self._route_id,
            tuple((w.x, w.y, w.yaw) for w in route.waypoints),
            node_ids,
            approach_tolerance=cfg.approach_tolerance,
            goal_tolerance=cfg.goal_tolerance * ROBOT_TOLERANCE_SHARE,
            yaw_tolerance=cfg.yaw_tolerance * ROBOT_TOLERANCE_SHARE,
        )
        self.route = msg
        self.route_index = 0
        self.goal_reached = False
        self._route_pending = not self._send(Topic.ROUTE, msg)
        if self._route_pending:
            self.log("warning", f"no robot received route {msg.route_id}; resending each tick")
        self.log("info", f"route {msg.route_id}: nodes {list(node_ids)}")
        self.route_sent.emit(msg)

    def _cancel_route(self, reason: str) -> None:
        """Tell the robot to drop the route in progress (``route_cancel``)."""
        self.log("info", f"route cancelled: {reason}")
        route_id = None if self.route is None else self.route.route_id
        self.route = None
        self._route_pending = False
        self._send(Topic.ROUTE_CANCEL, RouteCancel(route_id, reason, stamp=self.clock()))

    # ================================================================== operator commands
    def submit(self, task: Task, *, from_tablet: bool = False) -> bool:
        """Queue a task; False (and a logged reason) if the map rejects it."""
        try:
            events = self.supervisor.submit(task)
        except TaskRejectedError as exc:
            self.log("error", f"task rejected: {exc}")
            if from_tablet:
                self.tablet.send(p.ErrorReport("task_rejected", str(exc)[:500]))
            return False
        if from_tablet:
            self.tablet_tasks.append(task)
        self.log("info", f"queued: {describe_task(task, self.names)}")
        self._handle(events)
        self.tasks_changed.emit()
        return True

    def _try(self, action: Callable[[], list[Event]]) -> bool:
        try:
            events = action()
        except SupervisorError as exc:
            self.log("warning", str(exc))
            return False
        self._handle(events)
        self.tasks_changed.emit()
        return True

    def cancel_task(self) -> bool:
        return self._try(self.supervisor.cancel)

    def move_task(self, index: int, delta: int) -> bool:
        target = index + delta
        if not 0 <= target < len(self.supervisor.queue):
            return False
        return self._try(lambda: self.supervisor.reorder(index, target))

    def remove_task(self, index: int) -> bool:
        return self._try(lambda: self.supervisor.remove(index))

    def clear_queue(self) -> bool:
        return self._try(self.supervisor.clear_queue)

    def pause(self) -> None:
        self._handle(self.supervisor.pause())

    def resume(self) -> None:
        self._handle(self.supervisor.resume())

    def tour_resume(self) -> bool:
        """Leave the tour stop: release the pause and drive to the next stop."""
        ok = self._try(self.supervisor.tour_resume)
        if ok:
            self.goal_reached = False
            self.resume()
        return ok

    def tour_end(self) -> bool:
        ok = self._try(self.supervisor.tour_end)
        if ok:
            self.resume()
        return ok

    def answer_request(self, accepted: bool) -> bool:
        return self._try(lambda: self.supervisor.request_response(accepted))

    def emergency_stop(self) -> None:
        """Engage the stop lock; it latches (here and on the robot) until `release_stop`."""
        self.teleop.release_all()
        self._send(Topic.STOP, Lock(True, stamp=self.clock()))
        if not self.estop_latched:
            self.estop_latched = True
            self.log("error", "EMERGENCY STOP engaged")
            self.estop_changed.emit(True)

    def release_stop(self) -> None:
        if not self.estop_latched:
            return
        now = self.clock()
        self._send(Topic.STOP, Lock(False, stamp=now))
        self._send(Topic.STOP_RELEASE, StopRelease("base station", stamp=now))
        self.estop_latched = False
        self.log("info", "emergency stop released")
        self.estop_changed.emit(False)

    def set_initial_pose(self, pose: Pose2D) -> None:
        now = self.clock()
        self._send(Topic.INITIAL_POSE, InitialPose(pose.x, pose.y, pose.yaw, stamp=now))
        # Until the robot reports the pose applied, its last "unset"/"lost" is stale: holding
        # it back keeps the tablet's "Help me!" banner from flashing up again (and the state is
        # said afresh once the robot answers or the grace runs out).
        self._pose_settling_until = now + INITIAL_POSE_SETTLE_S
        self._localisation_sent = None
        self.log("info", f"initial pose set to ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f} rad)")

    def set_initial_pose_room(self, node_id: int) -> None:
        self.set_initial_pose(self.topo.node(node_id, "room").pose)

    def set_config(self, config: StationConfig) -> None:
        """Apply new parameters at once: supervisor tolerances, teleop limits, watchdog, robot."""
        self.config = config
        self.supervisor.config = config.supervisor_config(self.supervisor.config.request_timeout)
        self.teleop.set_limits(config.teleop_linear_max, config.teleop_angular_max)
        self.watchdog.ceiling_s = config.latency_ceiling
        self._config_pending = not self._send(Topic.CONFIG, ConfigMsg(config.planner_params()))
        self.config_changed.emit(config)

    # ------------------------------------------------------------------ teleoperation
    def _teleop_changed(self) -> None:
        """Send at once on every change (the clock repeats it); a zero when all is released."""
        now = self.clock()
        if self.teleop.active and not self.estop_latched:
            linear, angular = self.teleop.command()
            self._send(Topic.STATION_VEL, Twist(linear, angular, stamp=now))
        elif self._teleop_was_active:
            self._send(Topic.STATION_VEL, Twist(0.0, 0.0, stamp=now))
        self._teleop_was_active = self.teleop.active

    def press(self, direction: Direction) -> None:
        if self.estop_latched:
            return
        self.teleop.press(direction)
        self._teleop_changed()

    def release(self, direction: Direction) -> None:
        self.teleop.release(direction)
        self._teleop_changed()

    def set_joystick(self, linear: float, angular: float, pressed: bool) -> None:
        if self.estop_latched and pressed:
            return
        self.teleop.set_joystick(linear, angular, pressed)
        self._teleop_changed()

    def release_all(self) -> None:
        """Focus lost: stop teleoperating at once."""
        if self.teleop.active:
            self.teleop.release_all()
            self._teleop_changed()

    # ================================================================== tablet
    def _on_tablet_connected(self, peer: str) -> None:
        self._localisation_sent = None
        self._tour_state_sent = None
        self._status_sent = None
        self.watchdog.reset()
        self.tablet.send(self.permissions.to_message())
        self.log("info", f"tablet connected from {peer}")
        self.tablet_changed.emit()

    def _on_tablet_disconnected(self) -> None:
        self.tablet_speed = None
        if self.tablet_forwarding:
            self._send(Topic.TABLET_VEL, Twist(0.0, 0.0, stamp=self.clock()))
            self.tablet_forwarding = False
        self.watchdog.reset()
        self.log("warning", "tablet disconnected")
        self.tablet_changed.emit()

    def _on_latency(self, rtt: float) -> None:
        self.latencies.append(rtt)
        self.latency_added.emit(rtt)
        self.tablet_changed.emit()

    def set_permission(self, kind: str, allowed: bool) -> None:
        self.permissions = self.permissions.with_kind(kind, allowed)
        self.tablet.send(self.permissions.to_message())
        self.log("info", f"tablet {kind} {'allowed' if allowed else 'forbidden'}")
        self.tablet_changed.emit()

    def _is_tablet_task(self, task: Task | None) -> bool:
        return task is not None and any(t is task for t in self.tablet_tasks)

    @property
    def tablet_task(self) -> Task | None:
        """The running task if the tablet ordered it."""
        task = self.supervisor.current_task
        return task if self._is_tablet_task(task) else None

    def tablet_task_override(self) -> None:
        """The operator takes the tablet's task over: it continues as a station task."""
        task = self.tablet_task
        if task is not None:
            self.tablet_tasks = [t for t in self.tablet_tasks if t is not task]
            self.tablet.send(p.Cancel("task taken over by the operator"))
            self.log("info", f"operator took over: {describe_task(task, self.names)}")
            self.tablet_changed.emit()

    def tablet_task_stop(self) -> None:
        """Stop the tablet's task where it is (pause navigation; resume continues it)."""
        if self.tablet_task is not None:
            self.pause()

    def tablet_task_cancel(self) -> None:
        task = self.tablet_task
        if task is not None:
            self.cancel_task()
            self.tablet.send(p.Cancel("cancelled by the operator"))

    def on_tablet_message(self, msg: object) -> None:
        """A validated tablet message: a Supervisor or robot action, subject to permissions."""
        now = self.clock()
        kind = permission_for(msg)  # type: ignore[arg-type]
        if not self.permissions.allows(kind):
            self.tablet.send(
                p.ErrorReport(
                    "not_permitted", f"the operator does not allow {kind} from the tablet"
                )
            )
            if not isinstance(msg, p.Speed):
                self.log("warning", f"tablet {type(msg).__name__} refused: {kind} not allowed")
            return
        if isinstance(msg, p.Speed):
            self.watchdog.feed(now)
            self.tablet_periods.add_arrival(now)
            self.tablet_speed = msg
            # Forward at once (fresh by definition); clock() republishes it every period while
            # the watchdog keeps it fresh, as the thesis's speed section does (§5.3.6).
            self._send(Topic.TABLET_VEL, Twist(msg.linear, msg.angular, stamp=now))
            self.tablet_forwarding = True
        elif isinstance(msg, p.Goal):
            self.submit(GoTo(msg.node), from_tablet=True)
        elif isinstance(msg, p.Home):
            self.submit(GoHome(), from_tablet=True)
        elif isinstance(msg, p.Pause):
            self.pause() if msg.paused else self.resume()
        elif isinstance(msg, p.Stop):
            if msg.stop:
                self.log("warning", "tablet: stop")
                self.cancel_task()
        elif isinstance(msg, p.Tour):
            if msg.start:
                self.submit(GuidedTour(), from_tablet=True)
            elif isinstance(self.supervisor.current_task, GuidedTour):
                self.tour_end()
        elif isinstance(msg, p.TourControl):
            self.tour_resume() if msg.action == "resume" else self.tour_end()
        elif isinstance(msg, p.RequestFrom):
            if msg.status:
                self.submit(Delivery(msg.request, msg.room, msg.deliver_to), from_tablet=True)
        elif isinstance(msg, p.RequestAnswer):
            if self.shown_request is not None and self.shown_request[0] == msg.id:
                self.answer_request(msg.accepted)
            else:
                self.tablet.send(p.ErrorReport("unknown_request", f"no request {msg.id} is shown"))
        elif isinstance(msg, p.InitialPoseRoom):
            self.set_initial_pose_room(msg.room)
        elif isinstance(msg, p.Malfunction):
            self.log("error", f"tablet reports {msg.kind}: {msg.text}")
        self.tablet_changed.emit()
