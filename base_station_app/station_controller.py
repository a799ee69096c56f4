"""The Base Station's controller: the composition root that wires the station's parts to Qt.

Thesis §5.3 and §5.3.6 (Fig. 5.12): after start-up (TCP server listening, timers started, the
robot link open, the topological map loaded and every route precomputed) a `QTimer` calls
``clock()`` every 100 ms (``Qt.PreciseTimer``), which has three sections:

* **speed** - publish the station's teleoperation command on ``station_vel`` while a key, pad
  button or the mouse joystick is held (the tablet's commands are forwarded once, on arrival:
  see "Safety" below);
* **pose** - feed EVERY robot's pose to its own `Supervisor` (Algorithm 5 routes, tour stops,
  requests) and act on its events: send the whole route, cancel it, pause at tour stops;
* **communication** - send the tablet ``initial_pose: false`` until the robot is localised, then
  its ``pose``, the current ``goal`` with the ``reached`` / ``tourReached`` flags, the tour
  state, requests to show and status text (§5.3.2, §5.3.6).

A second, 25 ms frame timer pulls the newest robot state from the zenoh link (a ring of one per
topic) into each robot's `RobotState` and emits ``frame_ready`` at the display rate
(`DisplayRate`, 15 Hz: what arrived in between is coalesced, issue 14); views redraw from it,
never per message. Time comes from an injectable ``clock`` (``time.monotonic`` by default) so tests control
it. This object holds no widgets; the main window wires widgets to its signals and slots.

The parts it composes (issue 13: each named after what it owns, Qt-free and unit tested):

* `Fleet` (fleet.py) - a `RobotMirror` (robot_mirror.py) per robot: its state, supervisor (queue,
  tour, pause, requests), route mirror and must-arrive state; which robot is commanded, and the
  start-up choice (``--robot``, the saved choice, else ask when there are several: issue 14);
* `FleetLink` (fleet_link.py) - sending to the robots, the operator's stop intent and the other
  state every robot must hear until it has (re-sent on every clock while pending);
* `TeleopArbiter` (teleop_arbiter.py) - the station's keys and the tablet's joystick, freshness;
* `TabletPolicy` (tablet_policy.py) - what the tablet may do and which tasks it owns;
* `SupervisorEvents` (supervisor_events.py) - what every robot's supervisor events and the
  robot's word on its route become: routes sent and cancelled, tour stops, requests shown;
* `RobotReports` (robot_reports.py) - what the robots say, into their mirrors;
* `TaskCommands` (task_commands.py) - the operator's and the tablet's commands on the
  selected robot's tasks and pose (the task panel and the window call it directly);
* `TabletRequests` (tablet_requests.py) - what the tablet's requests become, with its
  permissions and ownership (its Stop cancels only what it ordered);
* `TabletLink` (tablet_link.py, the one Qt part: the tablet server's signals reach it queued
  on this thread) - what the tablet is told (permissions, the communication section) and what
  its connection events become;
* `AlertList` / `AlertRules` (alerts.py) - what the operator must see and acknowledge.

Beyond its parts it keeps only the operator's configuration, and no method of it only passes a
call on to one part (`tests/test_architecture.py` holds it to both, and to a line budget): a new
piece of state or a new decision goes to the part that owns it. What stays here coordinates
several parts at once under the speed path's lock (the e-stop, a robot switch, shutdown) or
runs the clock.

The selected robot is followed closely by `StationLink` (every topic); the others by a
`FleetWatch` (pose, plan, battery, multiplexer, safety, route progress, status) that also carries
their commands. The tablet and the operator's keys act on the selected robot only.

Safety (issue 11, shared/DESIGN.md "State has one owner"):

* **The stop is a state owned on both ends.** The operator's stop is kept here whether or not a
  robot heard it, and applies to EVERY robot of the fleet: re-asserted on every (re)connection
  and re-sent while a robot reports no stop; no motion is forwarded while it is engaged, the
  tablet's included. A robot starts latched after a restart; while the operator's stop is
  released the station releases that latch only on robots the operator has commanded (selected)
  from this station: a robot merely seen stays latched (drawn "stopped") until chosen.
* **The robot owns its route.** Route ids are random 63-bit numbers (unique across station
  restarts). A route is sent once, to the robot whose supervisor planned it; one that no robot
  received ends its task. After a reconnection the station asks the robot (`RouteMirror`) and
  never re-sends a route: a robot that lost it (restart) or finished it says so, and the task
  ends with that reason. A route the robot drives that this station did not start (station
  restart) is shown, and a stop from the operator or the tablet cancels it. Selecting another
  robot leaves each robot its own route and queue (per-robot supervision); the station's and the
  tablet's hand driving get one explicit zero on the robot they were driving.
* **Fresh commands only.** Each tablet speed command is checked (`SpeedFreshness`: out-of-order
  or late ones are dropped), forwarded once stamped with its arrival time, and restarts a
  single-shot `QTimer` (thesis Fig. 5.10) of the latency ceiling whose timeout sends one
  explicit zero. Nothing re-stamps an old command.
* **Off the drawing thread (issue 14).** The tablet server and `TabletTeleop` run in their own
  thread: a speed command is read, checked and forwarded there, never behind a frame being
  drawn here. This object changes what gates the tablet (the e-stop, the selected robot, the
  link) under ``tablet_teleop.lock``, so the e-stop wins over a command in flight.
* **The tablet knows.** While the robot is offline the tablet gets no stale pose, the status
  "robot offline" and permissions that offer nothing (no teleop while the stop is engaged).
"""

from __future__ import annotations

import logging
import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh
from PySide6.QtCore import QObject, Qt, QTimer, Signal

from base_station_app.alerts import AlertList, AlertRules
from base_station_app.fleet import Ask, Fleet, Select
from base_station_app.fleet_link import FleetLink
from base_station_app.robot_mirror import RobotMirror
from base_station_app.robot_reports import RobotReports
from base_station_app.robot_state import RobotState
from base_station_app.station_config import StationConfig
from base_station_app.station_file import StationFileError, StationSettingsStore
from base_station_app.supervisor_events import Notices, SupervisorEvents
from base_station_app.tablet_auth import TabletAuthServer
from base_station_app.tablet_link import TabletLink
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.tablet_requests import TabletRequests
from base_station_app.tablet_server import TabletServer
from base_station_app.tablet_teleop import TabletTeleop
from base_station_app.task_commands import TaskCommands
from base_station_app.teleop import Direction
from base_station_app.teleop_arbiter import TeleopArbiter
from interbot_core import protocol as p
from interbot_core.display_rate import DEFAULT_DISPLAY_HZ, DisplayRate
from interbot_core.occupancy_grid import MapLoadError, OccupancyGrid, load_map
from interbot_core.rooms import load_room_map, room_map
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import Task
from interbot_core.topics import ConfigMsg, Topic, Twist
from interbot_core.topological_map import TopologicalMap
from interbot_core.watchdog import PeriodStats
from interbot_link import StationLink
from interbot_link.command_priority import SCAN_PERIOD_S
from interbot_link.fleet_watch import FleetWatch

logger = logging.getLogger(__name__)

Clock = Callable[[], float]

NETWORK_THREAD_SCAN_MS = round(SCAN_PERIOD_S * 1000)  # [ms] the daemon's period too


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
    choice_grace_ms: int = 2000  # after the first robot: discovery before picking it or asking


class StationController(QObject):
    """State, commands and the control loop of the Base Station (see the module docstring)."""

    frame_ready = Signal()
    alert_raised = Signal(object)  # Alert: new, or a repeat of an unacknowledged one
    clocked = Signal()
    _log_requested = Signal(str, str)  # a log line from the tablet thread (queued to ours)
    robots_changed = Signal()
    robot_selected = Signal(str)
    robot_choice_needed = Signal(object)  # tuple[str, ...]: several robots, no choice: ask
    tasks_changed = Signal()
    log_added = Signal(str, str)  # level, text
    estop_changed = Signal(bool)
    paused_changed = Signal(bool)
    config_changed = Signal(object)
    tour_stop_reached = Signal(object)  # TourStopReached
    request_shown = Signal(object)  # RequestShown
    route_sent = Signal(object)  # RouteMsg

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
        settings: StationSettingsStore | None = None,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self.tablet_auth = tablet_auth  # TLS + pairing (issue 15); None: plaintext thesis tablet
        self.clock = clock
        self.topo = topo
        self.names = {n.id: n.name for n in topo.nodes}
        self.planner = RoutePlanner(topo)  # Floyd-Warshall: every route precomputed (§5.3.3)
        # The station file owns config and permissions (station_file.py): read once, written
        # on every change the operator makes. None (tests): nothing is kept.
        self.settings = settings
        saved = settings.load() if settings is not None else None
        self.config = config or (saved.config if saved is not None else StationConfig())
        self._request_timeout = self.config.supervisor_config().request_timeout
        self.rooms = load_room_map(topo_path, topo) if topo_path is not None else room_map(topo)
        self.static_map = self._load_static_map()
        # One status log for the station, whichever robot is selected: every mirror's
        # `RobotState` shares it (the state panel and tests read ``state.log``).
        self.status_log = RobotState().log
        self.fleet = Fleet(self._make_mirror, robot_id, timing.choice_grace_ms / 1000.0)
        self.alerts = AlertList()  # what the operator must see and acknowledge (alerts.py)
        self.alert_rules = AlertRules(self.alerts)
        self.alerts.subscribe(self.alert_raised.emit)
        self.arbiter = TeleopArbiter(
            self.config.latency_ceiling,
            self.config.teleop_linear_max,
            self.config.teleop_angular_max,
        )
        self.tablet_policy = TabletPolicy()
        if saved is not None:
            self.tablet_policy.permissions = saved.tablet.permissions()
        self.clock_periods = PeriodStats(5000)
        self._log_requested.connect(self.log)
        # Sending to the robots and what each must hear: the stop, config, assist (fleet_link.py).
        self.robot_link = FleetLink(
            StationLink(session) if session is not None else None,
            FleetWatch(session) if session is not None else None,
            self.fleet,
            clock,
            self._log_requested.emit,  # also from the tablet thread: queued to ours
            ConfigMsg(self.config.planner_params()),
        )
        # The tablet server and its speed path live in their own thread from `start` on (no
        # parent: they move there); their signals reach this object's slots queued.
        self.tablet = TabletServer(
            clock,
            tablet_host,
            tablet_port,
            robot_name=lambda: self.selected_robot or "none",
            limits=p.ProtocolLimits(node_ids=frozenset(self.names)),
            ping_interval_ms=timing.ping_ms,
            server=tablet_auth,
        )
        self.tablet_teleop = TabletTeleop(
            self.arbiter,
            clock,
            self.robot_link,
            self.tablet_policy,
            send_twist=lambda twist: self._send(Topic.TABLET_VEL, twist),  # late: tests wrap it
            reply=self.tablet.send,
            latency_ceiling=self.config.latency_ceiling,
            parent=self.tablet,
        )
        # What the supervisors' events and the tablet's requests become (Qt-free parts).
        notices = Notices(
            self.log,
            self.tasks_changed.emit,
            self.paused_changed.emit,
            self.tour_stop_reached.emit,
            self.request_shown.emit,
            self.route_sent.emit,
        )
        self.events = SupervisorEvents(
            self.fleet,
            self.robot_link,
            self.tablet.send,
            self.tablet_policy,
            self.alerts,
            notices,
            self.config,
            self.names,
            clock,
            route_ids,
        )
        self.commands = TaskCommands(
            self.fleet,
            self.events,
            self.robot_link,
            self.tablet_policy,
            self.tablet.send,
            self.tablet_teleop.stop,
            topo,
            notices,
            clock,
        )
        self.tablet_requests = TabletRequests(
            self.tablet_policy,
            self.fleet,
            self.commands,
            self.tablet.send,
            self.alert_rules,
            self.names,
            clock,
        )
        self.tablet.speed_received.connect(self.tablet_teleop.on_speed)  # in the tablet thread
        self.tablet.disconnected.connect(self.tablet_teleop.on_tablet_disconnected)  # idem
        # The tablet's signals on this (the Qt) thread: what it is told, its requests.
        # What the robots say, into their mirrors (robot_reports.py).
        self.reports = RobotReports(
            self.fleet,
            self.robot_link,
            self.events,
            self.alert_rules,
            self.tablet_teleop.lock,
            self.log,
            self.robots_changed.emit,
            clock,
        )
        self.tablet_link = TabletLink(
            self.tablet,
            self.tablet_teleop,
            self.tablet_requests,
            self.fleet,
            self.robot_link,
            self.alert_rules,
            self.names,
            self.log,
            clock,
            parent=self,
        )

        self.clock_timer = QTimer(self)
        self.clock_timer.setTimerType(Qt.TimerType.PreciseTimer)
        self.clock_timer.setInterval(timing.clock_ms)
        self.clock_timer.timeout.connect(self.tick)
        self.frame_timer = QTimer(self)
        self.frame_timer.setInterval(timing.frame_ms)
        self.frame_timer.timeout.connect(self._on_frame_timer)
        self.display_rate = DisplayRate(timing.display_hz)  # draw at most this often
        # zenoh's transmit threads to the tablet thread's priority (fleet_link.py), looked for
        # every second while a session is open (zenoh starts them as links come up).
        self.network_timer = QTimer(self)
        self.network_timer.setInterval(NETWORK_THREAD_SCAN_MS)
        self.network_timer.timeout.connect(self.robot_link.raise_network_threads)
        self._session_open = session is not None

    def _make_mirror(self, robot_id: str | None) -> RobotMirror:
        mirror = RobotMirror(
            robot_id,
            self.topo,
            self.planner,
            self.config.supervisor_config(self._request_timeout),
        )
        mirror.state.log = self.status_log
        if hasattr(self, "robot_link") and self.estop_latched:  # (the first is made before)
            mirror.supervisor.hold_queue()  # nothing queued there yet: no events to act on
        return mirror

    # ================================================================== the selected robot
    # The operator, the panels and the tablet act on the selected robot: these name its parts.
    @property
    def selected(self) -> RobotMirror:
        return self.fleet.selected

    @property
    def robots(self) -> dict[str, bool]:
        """Robot id -> present, for every robot seen."""
        return {r: m.online for r, m in sorted(self.fleet.mirrors.items())}

    @property
    def link(self) -> StationLink | None:
        return self.robot_link.link

    @property
    def estop_latched(self) -> bool:
        """The operator's stop, for every robot (owned by `FleetLink`)."""
        return self.robot_link.estop_latched

    # ================================================================== lifetime
    def start(self, timers: bool = True) -> bool:
        """Listen for the tablet and start the timers; False if the tablet port is taken.

        ``timers=False`` leaves ``tick`` / ``poll_link`` to the caller (tests step them).
        """
        ok = self.tablet_link.start()
        if timers:
            self.clock_timer.start()
            self.frame_timer.start()
            if self._session_open:
                self.robot_link.raise_network_threads()
                self.network_timer.start()
        self.log("info", f"station started; {len(self.topo)} nodes, routes precomputed")
        return ok

    def shutdown(self) -> None:
        """Stop timers, stop the robot if teleoperated, close the tablet and the link (idempotent)."""
        if self.robot_link.closed:
            return
        self.clock_timer.stop()
        self.frame_timer.stop()
        self.network_timer.stop()
        with self.tablet_teleop.lock:  # no tablet command after this zero
            if self.arbiter.stop_tablet():
                self._send(Topic.TABLET_VEL, Twist(0.0, 0.0, stamp=self.clock()))
            if self.arbiter.keys.active:
                self.arbiter.keys.release_all()
                self._send(Topic.STATION_VEL, Twist(0.0, 0.0, stamp=self.clock()))
            self.robot_link.closed = True
        self.tablet.stop_thread()
        with self.tablet_teleop.lock:
            self.robot_link.close()
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
        return self.selected.state.grid if self.selected.state.grid is not None else self.static_map

    def log(self, level: str, text: str) -> None:
        self.selected.state.add_log(self.clock(), level, text)
        self.log_added.emit(level, text)

    # ================================================================== robot link
    def _send(self, topic: Topic, message: object) -> bool:
        """Send to the selected robot (also in the tablet thread: its speed, `TabletTeleop`)."""
        return self.robot_link.send(topic, message)

    def select_robot(self, robot_id: str | None) -> None:
        """Command ``robot_id`` from now on; every robot keeps its own queue and route.

        Hand driving (the station's keys, the tablet's joystick) is zeroed on the robot it drove
        before the switch; the tablet is bound to the new robot from now on.
        """
        if self.link is None or robot_id == self.link.selected:
            return
        self.release_all()
        link, selected = self.link, self.fleet.select

        def switch() -> tuple[RobotMirror, RobotMirror]:
            pair = selected(robot_id)
            link.select_robot(robot_id)  # the tablet thread publishes on its publishers
            return pair

        # The tablet's zero and the switch under one hold of the speed path's lock: no tablet
        # command reaches the old robot after its zero.
        switched: list[tuple[RobotMirror, RobotMirror]] = []
        self.tablet_teleop.stop("robot switched", then=lambda: switched.append(switch()))
        old, new = switched[0]
        self.robot_link.sync_watch()
        now = self.clock()
        new.state.scan = None  # no stale laser drawn from a robot followed lightly until now
        new.state.image = None
        for mirror in (old, new):
            if mirror.robot_id is not None:
                mirror.connected(now)  # new publishers / subscribers: re-assert, ask its route
                if mirror is old and old.online:
                    self.link.request_state(old.robot_id)
        self.tablet_link.feed.forget()
        self.tablet.send(p.RobotName(robot_id or "none"))  # its welcome named the old one
        self.log("info", f"commanding robot {robot_id}" if robot_id else "no robot selected")
        self.robot_selected.emit(robot_id or "")
        self.robots_changed.emit()
        self.tasks_changed.emit()
        self.robot_link.resend_pending(new)  # must-arrive state: stop intent, config, assist

    @property
    def selected_robot(self) -> str | None:
        return None if self.link is None else self.link.selected

    def _on_frame_timer(self) -> None:
        """Poll the link every frame tick; draw (``frame_ready``) only at the display rate, so
        the Qt thread that forwards the tablet's commands spends little time drawing."""
        self.poll_link(display=self.display_rate.due(self.clock()))

    def poll_link(self, display: bool = True) -> None:
        """What the robots said (robot_reports.py), the start-up choice, then ``frame_ready``
        (``display``: a frame is drawn)."""
        if self.link is not None:
            self.reports.poll(display)
            self._choose_robot()
        if display:
            self.frame_ready.emit()

    def _choose_robot(self) -> None:
        """The start-up choice (fleet.py): select the preferred or only robot, or ask."""
        choice = self.fleet.choose(self.clock())
        if isinstance(choice, Select):
            self.select_robot(choice.robot_id)
        elif choice is not None:  # several robots and no choice, or the preferred one absent
            self.log("warning", choice.text)
            if isinstance(choice, Ask):
                self.robot_choice_needed.emit(choice.robot_ids)

    # ================================================================== clock()
    def tick(self) -> None:
        """The control loop (thesis Fig. 5.12): speed, pose (every robot), communication."""
        now = self.clock()
        self.clock_periods.add_arrival(now)
        self._choose_robot()
        for mirror in self.fleet.all():
            self.robot_link.resend_pending(mirror)
            self.robot_link.check_stop(now, mirror)
            for lost in mirror.due_losses(now):
                self.events.route_lost(lost, mirror)
        self._speed_section(now)
        self.events.update_poses(now)
        self.tablet_link.communicate(now)
        self.clocked.emit()

    def _speed_section(self, now: float) -> None:
        """The station's own teleoperation, repeated while held (the operator is present).

        The tablet's commands are not repeated here: each is forwarded once, on arrival
        (tablet_teleop.py), and the single-shot watchdog sends the zero.
        """
        command = self.arbiter.keys_command(self.estop_latched)
        if command is not None:
            self._send(Topic.STATION_VEL, Twist(command[0], command[1], stamp=now))

    @property
    def robot_online(self) -> bool:
        return self.robot_link.robot_online

    # ================================================================== operator commands
    # The task commands are `self.commands` (task_commands.py); the safety tests queue and
    # resume through these two names.
    def submit(self, task: Task, *, from_tablet: bool = False) -> bool:
        return self.commands.submit(task, from_tablet=from_tablet)

    def resume_queue(self) -> None:
        self.commands.resume_queue()

    def emergency_stop(self) -> None:
        """Engage the stop lock on EVERY robot; it latches (here and on them) until released.

        The operator's stop is kept here even if no robot heard it, and delivered (and
        re-asserted) whenever a robot is connected.
        """
        self.arbiter.keys.release_all()
        with self.tablet_teleop.lock:  # from here on no tablet command is forwarded
            was = self.estop_latched
            self.robot_link.estop_latched = True
        self.tablet_teleop.stop("emergency stop")
        for mirror in self.fleet.all():
            # waiting tasks wait for "Resume queue"
            self.events.handle(mirror.supervisor.hold_queue(), mirror)
            self.robot_link.assert_stop_intent(mirror)
        if self.selected.stop_assert_pending:
            self.log("error", "robot unreachable: the stop is kept and sent when it reconnects")
        if not was:
            self.log("error", "EMERGENCY STOP engaged")
            self.estop_changed.emit(True)

    def release_stop(self) -> None:
        if not self.estop_latched:
            return
        with self.tablet_teleop.lock:
            self.robot_link.estop_latched = False
            self.arbiter.told = None  # a refused speed is explained again
        for mirror in self.fleet.all():
            self.robot_link.assert_stop_intent(mirror)
        self.log("info", "emergency stop released")
        self.estop_changed.emit(False)

    def set_config(self, config: StationConfig) -> None:
        """Apply new parameters at once: supervisor tolerances, teleop limits, watchdog, robots."""
        self.config = self.events.config = config
        for mirror in self.fleet.all():
            mirror.supervisor.config = config.supervisor_config(self._request_timeout)
        with self.tablet_teleop.lock:
            self.arbiter.set_limits(
                config.latency_ceiling, config.teleop_linear_max, config.teleop_angular_max
            )
        self.tablet_teleop.set_ceiling(config.latency_ceiling)
        self.robot_link.set_config(ConfigMsg(config.planner_params()))
        self._save_settings()
        self.config_changed.emit(config)

    def _save_settings(self) -> None:
        """Keep what the operator changed in the station file; say so if it cannot be written."""
        if self.settings is None:
            return
        try:
            self.settings.save(self.config, self.tablet_policy.permissions)
        except StationFileError as exc:
            self.log("warning", f"{exc} (the change applies until the station stops)")

    # ------------------------------------------------------------------ teleoperation
    def _teleop_changed(self) -> None:
        """Send at once on every change (the clock repeats it); a zero when all is released."""
        command = self.arbiter.keys_changed(self.estop_latched)
        if command is not None:
            self._send(Topic.STATION_VEL, Twist(command[0], command[1], stamp=self.clock()))

    def press(self, direction: Direction) -> None:
        if self.estop_latched:
            return
        self.arbiter.keys.press(direction)
        self._teleop_changed()

    def release(self, direction: Direction) -> None:
        self.arbiter.keys.release(direction)
        self._teleop_changed()

    def set_joystick(self, linear: float, angular: float, pressed: bool) -> None:
        if self.estop_latched and pressed:
            return
        self.arbiter.keys.set_joystick(linear, angular, pressed)
        self._teleop_changed()

    def release_all(self) -> None:
        """Focus lost: stop teleoperating at once."""
        if self.arbiter.keys.active:
            self.arbiter.keys.release_all()
            self._teleop_changed()

    # ================================================================== tablet
    def set_permission(self, kind: str, allowed: bool) -> None:
        """The operator's choice for the tablet (tablet_link.py), kept in the station file."""
        self.tablet_link.set_permission(kind, allowed)
        self._save_settings()
