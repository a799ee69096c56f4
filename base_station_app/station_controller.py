"""The Base Station's controller: ``clock()`` and everything the operator and the tablet command.

Thesis §5.3 and §5.3.6 (Fig. 5.12): after start-up (TCP server listening, timers started, the
robot link open, the topological map loaded and every route precomputed) a `QTimer` calls
``clock()`` every 100 ms (``Qt.PreciseTimer``), which has three sections:

* **speed** - publish the station's teleoperation command on ``station_vel`` while a key, pad
  button or the mouse joystick is held (the tablet's commands are forwarded once, on arrival:
  see "Safety" below);
* **pose** - feed the robot's pose to the `Supervisor` (Algorithm 5 routes, tour stops,
  requests) and act on its events: send the whole route, cancel it, pause at tour stops;
* **communication** - send the tablet ``initial_pose: false`` until the robot is localised, then
  its ``pose``, the current ``goal`` with the ``reached`` / ``tourReached`` flags, the tour
  state, requests to show and status text (§5.3.2, §5.3.6).

A second, 25 ms frame timer pulls the newest robot state from the zenoh link (a ring of one per
topic) into `RobotState` and emits ``frame_ready`` at the display rate (`DisplayRate`, 15 Hz:
what arrived in between is coalesced); views redraw from it, never per message.
Time comes from an injectable ``clock`` (``time.monotonic`` by default) so tests control it.
This object holds no widgets; the main window wires widgets to its signals and slots.

Safety (issue 11, shared/DESIGN.md "State has one owner"):

* **The stop is a state owned on both ends.** The operator's stop is kept here whether or not a
  robot heard it, re-asserted on every (re)connection (a robot starts latched after a restart;
  if the operator's stop is released, the station releases the robot's), and re-sent while the
  robot reports no stop; no motion is forwarded while it is engaged, the tablet's included.
* **The robot owns its route.** Route ids are random 63-bit numbers (unique across station
  restarts). A route is sent once; one that no robot received ends its task. After a
  reconnection the station asks the robot (`RouteMirror`) and never re-sends a route: a robot
  that lost it (restart) or finished it says so, and the task ends with that reason. A route the
  robot drives that this station did not start (station restart) is shown, and a stop from the
  operator or the tablet cancels it. Selecting another robot cancels the route on the old one.
* **Fresh commands only.** Each tablet speed command is checked (`SpeedFreshness`: out-of-order
  or late ones are dropped), forwarded once stamped with its arrival time, and restarts a
  single-shot `QTimer` (thesis Fig. 5.10) of the latency ceiling whose timeout sends one
  explicit zero. Nothing re-stamps an old command.
* **The tablet knows.** While the robot is offline the tablet gets no stale pose, the status
  "robot offline" and permissions that offer nothing (no teleop while the stop is engaged).
"""

from __future__ import annotations

import logging
import math
import secrets
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh
from PySide6.QtCore import QObject, Qt, QTimer, Signal

from base_station_app.alerts import AlertList, AlertRules
from base_station_app.map_rooms import RoomArea, load_room_areas
from base_station_app.robot_state import RobotState
from base_station_app.station_config import StationConfig
from base_station_app.tablet_auth import TabletAuthServer
from base_station_app.tablet_server import TabletServer
from base_station_app.tablet_session import TabletPermissions, describe_task, permission_for
from base_station_app.teleop import Direction, TeleopInput
from interbot_core import protocol as p
from interbot_core.display_rate import DEFAULT_DISPLAY_HZ, DisplayRate
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import MapLoadError, OccupancyGrid, load_map
from interbot_core.route_follower import ROBOT_TOLERANCE_SHARE
from interbot_core.route_mirror import RouteLost, RouteMirror
from interbot_core.route_planner import RoutePlanner
from interbot_core.speed_freshness import SpeedFreshness
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
    Battery,
    ConfigMsg,
    InitialPose,
    Lock,
    PoseMsg,
    Relocalise,
    RouteCancel,
    RouteMsg,
    RouteProgress,
    Status,
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
#: [s] while the operator's stop is engaged and the robot reports none, re-send it this often.
STOP_REASSERT_S = 0.5


def random_route_id() -> int:
    """A fresh route id: 63 random bits, so a restarted station never repeats an old id."""
    return secrets.randbits(63)


@dataclass(frozen=True)
class Timing:
    """Timer intervals [ms]; tests shorten them."""

    clock_ms: int = 100  # thesis §6.4: commands every 100 ms
    frame_ms: int = 25  # link poll (40 Hz, the laser's rate): state for the logic, no drawing
    ping_ms: int = 1000  # tablet latency probe
    display_hz: float = DEFAULT_DISPLAY_HZ  # frame_ready (drawing), coalesced (issue 14)


class StationController(QObject):
    """State, commands and the control loop of the Base Station (see the module docstring)."""

    frame_ready = Signal()
    alert_raised = Signal(object)  # Alert: new, or a repeat of an unacknowledged one
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
        route_ids: Callable[[], int] = random_route_id,
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
        self.alerts = AlertList()  # what the operator must see and acknowledge (alerts.py)
        self.alert_rules = AlertRules(self.alerts)
        self.alerts.subscribe(self.alert_raised.emit)
        self.teleop = TeleopInput(self.config.teleop_linear_max, self.config.teleop_angular_max)
        self.watchdog = LatencyWatchdog(
            self.config.latency_ceiling
        )  # latency shown to the operator
        self.freshness = SpeedFreshness(self.config.latency_ceiling)
        self.route_mirror = RouteMirror()
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
        self._route_ids = route_ids
        self._route_undelivered: int | None = None  # route no robot received: end its task
        self._stop_assert_pending = True  # (re)assert the operator's stop intent to the robot
        self._stop_sent_at = -math.inf
        self._tablet_stop_told = False  # the tablet was told why its speed is refused
        self._permissions_sent: p.Permissions | None = None
        self._verdict_of: int | None = None  # route whose end the robot reported, if handled
        self._last_clock: float | None = None
        self._tour_state_sent: p.TourState | None = None
        self._status_sent: p.StatusInfo | None = None
        self._localisation_sent: str | None = None
        self._safety_sent: p.SafetyInfo | None = None
        self._pose_settling_until = -math.inf  # see INITIAL_POSE_SETTLE_S
        self._teleop_was_active = False
        self._config_pending = True  # (re)send the planner config until a robot receives it
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
        self.frame_timer.timeout.connect(self._on_frame_timer)
        self.display_rate = DisplayRate(timing.display_hz)  # draw at most this often
        # Thesis Fig. 5.10: a single-shot timer restarted by every tablet speed command; its
        # timeout means the tablet went silent for the latency ceiling: one explicit zero.
        self.tablet_watchdog = QTimer(self)
        self.tablet_watchdog.setSingleShot(True)
        self.tablet_watchdog.setTimerType(Qt.TimerType.PreciseTimer)
        self.tablet_watchdog.setInterval(round(self.config.latency_ceiling * 1000))
        self.tablet_watchdog.timeout.connect(self._on_tablet_watchdog)

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
        self.tablet_watchdog.stop()
        if self.tablet_forwarding:
            self._send(Topic.TABLET_VEL, Twist(0.0, 0.0, stamp=self.clock()))
            self.tablet_forwarding = False
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
        if self.link.selected is not None and self.route is not None:
            # The route belongs to the robot that drives it: stop it there (nobody would watch
            # it any more) and end the task; it is never sent to the next robot.
            old = self.link.selected
            self._send(Topic.ROUTE_CANCEL, RouteCancel(self.route.route_id, "robot switched"))
            self._route_lost(
                RouteLost(self.route.route_id, f"robot switched from {old}; route cancelled there")
            )
        self.state.clear()
        self.link.select_robot(robot_id)
        self.log("info", f"commanding robot {robot_id}" if robot_id else "no robot selected")
        self.robot_selected.emit(robot_id or "")
        self._on_robot_connected()
        self._resend_pending()

    def _on_robot_connected(self) -> None:
        """A robot was selected or came back: assert the stop, send config, ask for the route."""
        self._config_pending = True
        self._assist_pending = True
        self._stop_assert_pending = True
        self.route_mirror.reconnected(self.clock())

    def _resend_pending(self) -> None:
        """Must-arrive state that found no subscriber (robot not yet linked, or restarted)."""
        if self._stop_assert_pending:
            self._assert_stop_intent()
        if self._config_pending:
            self._config_pending = not self._send(
                Topic.CONFIG, ConfigMsg(self.config.planner_params())
            )
        if self._assist_pending:
            msg = AssistMsg("station_vel", self.station_assist, stamp=self.clock())
            self._assist_pending = not self._send(Topic.TELEOP_ASSIST, msg)

    def _assert_stop_intent(self) -> None:
        """Tell the robot the operator's stop: engaged (re-sent) or released (its start latch)."""
        now = self.clock()
        if self.estop_latched:
            delivered = self._send(Topic.STOP, Lock(True, stamp=now))
        else:
            delivered = self._send(Topic.STOP, Lock(False, stamp=now)) and self._send(
                Topic.STOP_RELEASE, StopRelease("base station (on connection)", stamp=now)
            )
        self._stop_sent_at = now
        self._stop_assert_pending = not delivered

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

    def _on_frame_timer(self) -> None:
        """Poll the link every frame tick; draw (``frame_ready``) only at the display rate, so
        the Qt thread that forwards the tablet's commands spends little time drawing."""
        self.poll_link(display=self.display_rate.due(self.clock()))

    def poll_link(self, display: bool = True) -> None:
        """Pull link events and (``display``) the newest state, then ``frame_ready``.

        Between frames only the events are taken: the state topics wait in their rings of one,
        so only the newest scan / pose is decoded, once per frame (issue 14).
        """
        link = self.link
        if link is not None:
            for event in link.poll_events():
                self._on_link_event(event)
            for topic, message in (link.poll_state() if display else {}).items():
                self.state.apply(topic, message)
                self._check_alerts(topic, message)
            progress, route = self.state.progress, self.route
            if progress is not None and route is not None and progress.route_id == route.route_id:
                self.route_index = progress.index
                self._robot_verdict(progress)
        if display:
            self.frame_ready.emit()

    def _check_alerts(self, topic: Topic, message: object) -> None:
        """The selected robot's state, through the alert rules (alerts.py)."""
        robot, now, rules = self.selected_robot or "?", self.clock(), self.alert_rules
        if isinstance(message, PoseMsg):
            rules.on_pose(robot, message, now)
        elif isinstance(message, Battery):
            rules.on_battery(robot, message, now)
        elif isinstance(message, RouteProgress):
            rules.on_route_progress(robot, message, now)
        elif isinstance(message, Status):
            rules.on_status(robot, message, now)

    def _on_route_progress(self, progress: RouteProgress) -> None:
        """Mirror the robot's route (see `RouteMirror`)."""
        lost = self.route_mirror.on_progress(progress)
        if lost is not None:
            self._route_lost(lost)

    def _route_lost(self, lost: RouteLost) -> None:
        """Our route is gone on the robot: the task ends; nothing is re-sent."""
        self.route_mirror.ended()
        if self.route is None or self.route.route_id != lost.route_id:
            return
        self.log("error", lost.reason)
        self.route = None
        self._handle(self.supervisor.robot_route_aborted(lost.reason))
        self.tasks_changed.emit()

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
                self.link.request_state()  # it came back (restart?): ask, never assume
                self._on_robot_connected()
            elif selected is None and self.preferred_robot in (None, event.robot_id):
                self.select_robot(event.robot_id)
        elif isinstance(event, RobotLeft):
            self.robots[event.robot_id] = False
            self.log("error", f"robot {event.robot_id} lost (liveliness token gone)")
            self.alert_rules.on_robot_left(event.robot_id, self.clock())
            self.robots_changed.emit()
        elif isinstance(event, StateMessage):
            if event.robot_id != self.selected_robot:
                return  # a late message from the robot we no longer follow
            self.state.apply(event.topic, event.message)
            self._check_alerts(event.topic, event.message)
            if event.topic is Topic.ROUTE_PROGRESS and isinstance(event.message, RouteProgress):
                self._on_route_progress(event.message)
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
        self._check_robot_stop(now)
        if self._route_undelivered is not None:
            route_id, self._route_undelivered = self._route_undelivered, None
            self._route_lost(RouteLost(route_id, f"no robot received route {route_id}"))
        lost = self.route_mirror.check_timeout(now)
        if lost is not None:
            self._route_lost(lost)
        self._speed_section(now)
        self._pose_section(now)
        self._communication_section(now)
        self.clocked.emit()

    def _check_robot_stop(self, now: float) -> None:
        """The operator's stop is engaged but the robot reports none: say it again."""
        if (
            self.estop_latched
            and self.state.estop_engaged is False
            and now - self._stop_sent_at >= STOP_REASSERT_S
        ):
            self.log("warning", "the robot reports no emergency stop: sending it again")
            self._assert_stop_intent()

    def _speed_section(self, now: float) -> None:
        """The station's own teleoperation, repeated while held (the operator is present).

        The tablet's commands are not repeated here: each is forwarded once, on arrival
        (`on_tablet_message`), and the single-shot watchdog sends the zero.
        """
        if self.teleop.active and not self.estop_latched:
            linear, angular = self.teleop.command()
            self._send(Topic.STATION_VEL, Twist(linear, angular, stamp=now))

    def _stop_tablet_speed(self, why: str) -> None:
        """Forget the tablet's command and send one explicit zero if one was forwarded."""
        self.tablet_watchdog.stop()
        self.tablet_speed = None
        if self.tablet_forwarding:
            self._send(Topic.TABLET_VEL, Twist(0.0, 0.0, stamp=self.clock()))
            self.tablet_forwarding = False
            self.tablet_discarded += 1
            self.log("warning", f"tablet speed stopped ({why}): explicit zero sent")

    def _on_tablet_watchdog(self) -> None:
        """Thesis Fig. 5.10: no speed command for the latency ceiling (§5.3.4)."""
        self._stop_tablet_speed(f"no command for {self.config.latency_ceiling:g} s")

    def _pose_section(self, now: float) -> None:
        events = self.supervisor.update(now, self.state.localised_pose)
        self._handle(events)

    def tablet_permissions(self) -> TabletPermissions:
        """What the tablet may do now: the operator's choice, and only what can work."""
        if not self.robot_online or self.estop_latched:
            # During a stop nothing the tablet orders could start: refused, with the reason,
            # rather than queued to start the moment the stop is released.
            return TabletPermissions(False, False, False, False)
        return self.permissions

    def _send_permissions(self) -> None:
        msg = self.tablet_permissions().to_message()
        if msg != self._permissions_sent and self.tablet.send(msg):
            self._permissions_sent = msg
            self._tablet_stop_told = False  # a refused speed is explained again

    def _communication_section(self, now: float) -> None:
        if not self.tablet.is_connected:
            return
        self._send_permissions()
        send = self.tablet.send
        if not self.robot_online:
            # No stale pose or goal: the status says "robot offline" (and why it cannot work).
            status = p.StatusInfo(self.task_text(), self.status_text())
            if status != self._status_sent:
                send(status)
                self._status_sent = status
            self._localisation_sent = None
            return
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
        foreign = self.route_mirror.foreign
        if task is None and foreign is not None:
            return f"route {foreign.route_id} (started before this station)"
        return "idle" if task is None else describe_task(task, self.names)

    @property
    def robot_online(self) -> bool:
        robot = self.selected_robot
        return robot is not None and self.robots.get(robot, False)

    def status_text(self) -> str:
        sup = self.supervisor
        if self.estop_latched:
            return "emergency stop engaged"
        if not self.robot_online:
            return "robot offline"
        foreign = self.route_mirror.foreign
        if sup.current_task is None and foreign is not None:
            return f"robot {foreign.state} on a route this station did not start; stop cancels it"
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
        ids = route.node_ids
        node_ids = tuple(n for n in ids if n is not None) if None not in ids else ()
        cfg = self.config
        msg = RouteMsg(
            self._route_ids(),
            tuple((w.x, w.y, w.yaw) for w in route.waypoints),
            node_ids,
            approach_tolerance=cfg.approach_tolerance,
            goal_tolerance=cfg.goal_tolerance * ROBOT_TOLERANCE_SHARE,
            yaw_tolerance=cfg.yaw_tolerance * ROBOT_TOLERANCE_SHARE,
        )
        self.route = msg
        self.route_index = 0
        self.goal_reached = False
        if self._send(Topic.ROUTE, msg):
            self.route_mirror.started(msg.route_id)
        else:
            # Sent once: a route is never delivered later, when nobody may expect it. The task
            # ends at the next clock() (not inside the supervisor's event handling).
            self._route_undelivered = msg.route_id
        self.log("info", f"route {msg.route_id}: nodes {list(node_ids)}")
        self.route_sent.emit(msg)

    def _cancel_route(self, reason: str) -> None:
        """Tell the robot to drop the route in progress (``route_cancel``)."""
        self.log("info", f"route cancelled: {reason}")
        route_id = None if self.route is None else self.route.route_id
        self.route = None
        self._route_undelivered = None
        self.route_mirror.ended()
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

    def cancel_task(self, who: str = "the operator") -> bool:
        """Cancel the running task; a tablet's task cancelled by someone else tells the tablet."""
        tablets = self._is_tablet_task(self.supervisor.current_task)
        cancelled = self._try(self.supervisor.cancel)
        if cancelled and tablets and who != "the tablet":
            self.tablet.send(p.Cancel(f"cancelled by {who}"))
        return cancelled

    def stop_motion(self, who: str) -> None:
        """Stop whatever runs: the task (if any), a route this station did not start, teleop."""
        if self.supervisor.current_task is not None:
            self.cancel_task(who)
        if self.route_mirror.robot_running and self.route is None:
            # A route from before a station restart (or one we lost track of): cancel it too.
            self._send(
                Topic.ROUTE_CANCEL, RouteCancel(None, f"stopped by {who}", stamp=self.clock())
            )
            self.route_mirror.foreign = None
            self.log("warning", f"{who}: cancelled the robot's route")
        self._stop_tablet_speed(f"stop from {who}")

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
        """Engage the stop lock; it latches (here and on the robot) until `release_stop`.

        The operator's stop is kept here even if no robot heard it, and delivered (and
        re-asserted) whenever a robot is connected.
        """
        self.teleop.release_all()
        self._stop_tablet_speed("emergency stop")
        self._handle(self.supervisor.hold_queue())  # waiting tasks wait for "Resume queue"
        was = self.estop_latched
        self.estop_latched = True
        self._assert_stop_intent()
        if self._stop_assert_pending:
            self.log("error", "robot unreachable: the stop is kept and sent when it reconnects")
        if not was:
            self.log("error", "EMERGENCY STOP engaged")
            self.estop_changed.emit(True)

    def resume_queue(self) -> None:
        """The operator's "Resume queue": waiting tasks may start again (not during a stop)."""
        if self.estop_latched:
            self.log("warning", "release the emergency stop before resuming the queue")
            return
        if self.supervisor.held:
            self._handle(self.supervisor.release_queue())
            self.log("info", "task queue resumed by the operator")

    def release_stop(self) -> None:
        if not self.estop_latched:
            return
        self.estop_latched = False
        self._tablet_stop_told = False
        self._assert_stop_intent()
        self.log("info", "emergency stop released")
        self.estop_changed.emit(False)

    def set_initial_pose(self, pose: Pose2D, verify: bool = False) -> None:
        """``verify``: a room rather than an exact pose; the robot confirms it by laser."""
        now = self.clock()
        self._send(
            Topic.INITIAL_POSE, InitialPose(pose.x, pose.y, pose.yaw, stamp=now, verify=verify)
        )
        # Until the robot reports the pose applied, its last "unset"/"lost" is stale: holding
        # it back keeps the tablet's "Help me!" banner from flashing up again (and the state is
        # said afresh once the robot answers or the grace runs out).
        self._pose_settling_until = now + INITIAL_POSE_SETTLE_S
        self._localisation_sent = None
        self.log("info", f"initial pose set to ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f} rad)")

    def set_initial_pose_room(self, node_id: int) -> None:
        self.set_initial_pose(self.topo.node(node_id, "room").pose, verify=True)

    def relocalise(self) -> None:
        """Ask the robot to find itself on the whole map (global localisation)."""
        self._send(Topic.RELOCALISE, Relocalise(stamp=self.clock()))
        self.log("info", "relocalisation requested")

    def set_config(self, config: StationConfig) -> None:
        """Apply new parameters at once: supervisor tolerances, teleop limits, watchdog, robot."""
        self.config = config
        self.supervisor.config = config.supervisor_config(self.supervisor.config.request_timeout)
        self.teleop.set_limits(config.teleop_linear_max, config.teleop_angular_max)
        self.watchdog.ceiling_s = config.latency_ceiling
        self.freshness.ceiling_s = config.latency_ceiling
        self.tablet_watchdog.setInterval(round(config.latency_ceiling * 1000))
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
        self.freshness.reset()
        self._tablet_stop_told = False
        self._permissions_sent = None
        self._send_permissions()
        self.log("info", f"tablet connected from {peer}")
        self.tablet_changed.emit()

    def _on_tablet_disconnected(self) -> None:
        self._stop_tablet_speed("tablet disconnected")
        self.watchdog.reset()
        self.log("warning", "tablet disconnected")
        self.tablet_changed.emit()

    def _on_latency(self, rtt: float) -> None:
        self.latencies.append(rtt)
        self.latency_added.emit(rtt)
        self.tablet_changed.emit()

    def set_permission(self, kind: str, allowed: bool) -> None:
        self.permissions = self.permissions.with_kind(kind, allowed)
        if not self.permissions.teleop:
            self._stop_tablet_speed("teleoperation not permitted")
        self._send_permissions()
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
        if self.tablet_task is not None:
            self.cancel_task()  # tells the tablet: cancelled by the operator

    def on_tablet_message(self, msg: object) -> None:
        """A validated tablet message: a Supervisor or robot action, subject to permissions."""
        now = self.clock()
        kind = permission_for(msg)  # type: ignore[arg-type]
        if not self.tablet_permissions().allows(kind):
            if not self.robot_online:
                why = f"the robot is offline: {kind} cannot work"
            elif self.permissions.allows(kind):
                why = f"emergency stop engaged: {kind} ignored"
            else:
                why = f"the operator does not allow {kind} from the tablet"
            if not (isinstance(msg, p.Speed) and self._tablet_stop_told):
                self.tablet.send(p.ErrorReport("not_permitted", why))  # once per 10 Hz stream
            if isinstance(msg, p.Speed):
                self._tablet_stop_told = True
            if not isinstance(msg, p.Speed):
                self.log("warning", f"tablet {type(msg).__name__} refused: {kind} not allowed")
            self.alert_rules.on_refused(why, now)
            return
        if isinstance(msg, p.Speed):
            self._on_tablet_speed(msg, now)
        elif isinstance(msg, p.Goal):
            self.submit(GoTo(msg.node), from_tablet=True)
        elif isinstance(msg, p.Home):
            self.submit(GoHome(), from_tablet=True)
        elif isinstance(msg, p.Pause):
            self.pause() if msg.paused else self.resume()
        elif isinstance(msg, p.Stop):
            if msg.stop:
                self._tablet_stop()
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
            self.alert_rules.on_malfunction(msg.kind, msg.text, now)
        self.tablet_changed.emit()

    def _tablet_stop(self) -> None:
        """The tablet's Stop always stops the robot; it cancels only what the tablet ordered.

        An operator's task is paused instead (the robot stops, the task stays the operator's)
        and the tablet is told why; its own task, a route nobody here owns, or teleoperation
        is stopped outright.
        """
        task = self.supervisor.current_task
        if task is not None and not self._is_tablet_task(task):
            self.log("warning", "tablet: stop on the operator's task: paused")
            self.pause()
            self._stop_tablet_speed("stop from the tablet")
            self.tablet.send(
                p.ErrorReport(
                    "not_owner", "paused: this task was given by the operator, who decides on it"
                )
            )
            return
        self.log("warning", "tablet: stop")
        self.stop_motion("the tablet")

    def _on_tablet_speed(self, msg: p.Speed, now: float) -> None:
        """Forward one fresh tablet command once, stamped with its arrival time ``now``."""
        self.watchdog.feed(now)
        self.tablet_periods.add_arrival(now)
        if self.estop_latched:
            if not self._tablet_stop_told:
                self._tablet_stop_told = True
                self.tablet.send(
                    p.ErrorReport("not_permitted", "emergency stop engaged: speed ignored")
                )
            return
        verdict = self.freshness.check(msg.seq, msg.t, now)
        if not verdict.fresh:
            self.tablet_discarded += 1
            logger.info("tablet speed dropped: %s", verdict.reason)
            return
        self.tablet_speed = msg
        self._send(Topic.TABLET_VEL, Twist(msg.linear, msg.angular, stamp=now))
        self.tablet_forwarding = True
        self.tablet_watchdog.start()  # restarted by every command (thesis Fig. 5.10)
