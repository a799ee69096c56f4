"""What the station does when a robot's supervisor (or the robot's word on its route) moves on.

Each robot has its own `Supervisor` (queue, tour, requests: per-robot supervision); its
events say what to do, and this object does it for the robot they came from: send the whole
route once (a fresh random id, the configured tolerances; to a robot that lost its pose, the
goal alone: `Supervisor.update`), cancel it, pause at a tour stop
(§5.3.6), show a request. The tablet is bound to the selected robot, so only that robot's
events reach it; another robot that needs the operator (a tour stop, a request) raises a
"waiting" alert naming it instead. The robot owns its route (issue 11): its progress report
drives the supervisor, and its "succeeded" / "aborted" / lost route settles the task.

Plain Python (issue 13): the controller passes its Qt signals in as `Notices`; tests pass
recorders.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from base_station_app.alerts import AlertList
from base_station_app.fleet import Fleet
from base_station_app.fleet_link import FleetLink
from base_station_app.robot_mirror import RobotMirror
from base_station_app.station_config import StationConfig
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.tablet_session import describe_task
from interbot_core import protocol as p
from interbot_core.route_mirror import RouteLost
from interbot_core.supervisor import (
    Event,
    GoalReached,
    IntermediateGoalReached,
    PauseNavigation,
    QueueChanged,
    RequestAccepted,
    RequestDeclined,
    RequestShown,
    RequestTimedOut,
    RobotCondition,
    RouteCancelled,
    RouteStarted,
    SupervisorState,
    TaskFinished,
    TaskStarted,
    TourStopReached,
)
from interbot_core.topics import Lock, RouteCancel, RouteMsg, Topic


@dataclass(frozen=True)
class Notices:
    """What the station's views are told (the controller's Qt signals, or a test's recorders)."""

    log: Callable[[str, str], object]  # level, text
    tasks_changed: Callable[[], object]
    paused_changed: Callable[[bool], object]  # the selected robot's navigation
    tour_stop_reached: Callable[[TourStopReached], object]  # likewise
    request_shown: Callable[[RequestShown], object]  # likewise
    route_sent: Callable[[RouteMsg], object]


class SupervisorEvents:
    """Acts on every robot's supervisor events (see the module docstring)."""

    def __init__(
        self,
        fleet: Fleet,
        robot_link: FleetLink,
        tablet_send: Callable[[p.StationMessage], object],
        policy: TabletPolicy,
        alerts: AlertList,
        notices: Notices,
        config: StationConfig,
        names: dict[int, str],
        clock: Callable[[], float],
        route_ids: Callable[[], int],
    ) -> None:
        self._fleet, self._link, self._tablet_send = fleet, robot_link, tablet_send
        self._policy, self._alerts, self._notices = policy, alerts, notices
        self.config = config  # the route tolerances; the controller replaces it on a change
        self._names, self._clock, self._route_ids = names, clock, route_ids
        self.request_id = 0  # the tablet answers a shown request by this id

    def log_for(self, mirror: RobotMirror, level: str, text: str) -> None:
        """Log about ``mirror``'s robot; another robot than the selected one is named."""
        self._notices.log(level, self._fleet.about(mirror, text))

    def handle(self, events: list[Event], mirror: RobotMirror | None = None) -> None:
        """Act on ``events`` from ``mirror``'s supervisor (default: the selected robot's)."""
        mirror = mirror if mirror is not None else self._fleet.selected
        for event in events:
            self._handle_one(event, mirror)

    # ------------------------------------------------------------------ the robot's word
    def update_poses(self, now: float) -> None:
        """Every robot's supervisor sees its own robot's pose (the clock's pose section), and
        whether a lost robot may be handed its next leg (`RobotCondition`)."""
        for mirror in self._fleet.all():
            pose = mirror.state.localised_pose
            self.handle(mirror.supervisor.update(now, pose, self.condition(mirror)), mirror)

    def condition(self, mirror: RobotMirror) -> RobotCondition:
        """What the supervisor needs beside the pose: connected, stopped (the robot's word or
        the operator's stop), and looking for a pose it had (the pose message's ``known``)."""
        pose = mirror.state.pose
        finding = pose is not None and pose.state in ("lost", "searching", "turning") and pose.known
        stopped = self._link.estop_latched or bool(mirror.state.estop_engaged)
        return RobotCondition(mirror.online, stopped, finding)

    def robot_progress(self, mirror: RobotMirror) -> None:
        """The robot judges arrival (issue 13): its report on our route drives the supervisor,
        and its end of the route (once) settles the task."""
        progress = mirror.route_progress()
        if progress is None:
            return
        self.handle(mirror.supervisor.robot_progress(progress.index), mirror)
        if not mirror.verdict(progress):
            return
        if progress.state == "succeeded":
            self.handle(mirror.supervisor.robot_route_succeeded(self._clock()), mirror)
        else:
            why = f"robot gave up route {progress.route_id}: {progress.reason}"
            self.log_for(mirror, "error", why)
            self.handle(mirror.supervisor.robot_route_aborted(progress.reason), mirror)

    def route_lost(self, lost: RouteLost, mirror: RobotMirror) -> None:
        """Our route is gone on the robot: the task ends; nothing is re-sent."""
        if mirror.lose_route(lost):
            self.log_for(mirror, "error", lost.reason)
            self.handle(mirror.supervisor.robot_route_aborted(lost.reason), mirror)
            self._notices.tasks_changed()

    # ------------------------------------------------------------------ one event
    def _tell_tablet(self, mirror: RobotMirror, message: p.StationMessage) -> None:
        """The tablet is bound to the selected robot: it hears of that robot only."""
        if mirror is self._fleet.selected:
            self._tablet_send(message)

    def _handle_one(self, event: Event, mirror: RobotMirror) -> None:
        mirror.on_event(event)
        selected, names, say = mirror is self._fleet.selected, self._names, self.log_for
        if isinstance(event, TaskStarted):
            say(mirror, "info", f"task started: {describe_task(event.task, names)}")
            self._notices.tasks_changed()
        elif isinstance(event, TaskFinished):
            level = "info" if event.ok else "warning"
            say(mirror, level, f"task {describe_task(event.task, names)}: {event.reason}")
            self._policy.forget(event.task)
            self._notices.tasks_changed()
        elif isinstance(event, QueueChanged):
            self._notices.tasks_changed()
        elif isinstance(event, RouteStarted):
            self._send_route(event, mirror)
        elif isinstance(event, RouteCancelled):
            say(mirror, "info", f"route cancelled: {event.reason}")
            cancel = RouteCancel(mirror.drop_route(), event.reason, stamp=self._clock())
            self._link.send_to(mirror, Topic.ROUTE_CANCEL, cancel)
        elif isinstance(event, IntermediateGoalReached):
            say(mirror, "info", f"intermediate goal {event.node} reached")
        elif isinstance(event, GoalReached):
            where = names.get(event.node, "pose") if event.node is not None else "pose"
            say(mirror, "info", f"goal reached: {where}")
            if event.node is not None:
                self._tell_tablet(mirror, p.GoalStatus(event.node, True, False))
        elif isinstance(event, PauseNavigation):
            self._link.send_to(mirror, Topic.PAUSE_NAV, Lock(event.paused, stamp=self._clock()))
            say(mirror, "info", "navigation paused" if event.paused else "navigation resumed")
            if selected:
                self._notices.paused_changed(event.paused)
        elif isinstance(event, TourStopReached):
            self.handle(mirror.supervisor.pause(), mirror)  # wait at the stop (§5.3.6)
            say(mirror, "info", f"tour stop {event.node} ({event.name}) reached; tour paused")
            self._tell_tablet(mirror, p.GoalStatus(event.node, True, True))
            if selected:
                self._notices.tour_stop_reached(event)
            else:
                self._waiting(mirror, f"at tour stop {event.name}: command it to resume")
        elif isinstance(event, RequestShown):
            self.request_id += 1
            mirror.shown_request = (self.request_id, event)
            room = names[event.room]
            self._tell_tablet(
                mirror, p.ShowRequest(self.request_id, event.text, event.room, event.deliver_to)
            )
            say(mirror, "info", f"request shown at {room}: {event.text}")
            if selected:
                self._notices.request_shown(event)
            else:
                self._waiting(mirror, f"shows a request at {room}: command it")
        elif isinstance(event, RequestAccepted | RequestDeclined | RequestTimedOut):
            verb = {RequestAccepted: "accepted", RequestDeclined: "declined"}.get(
                type(event), "timed out"
            )
            say(mirror, "info", f"request '{event.text}' {verb}")

    def _waiting(self, mirror: RobotMirror, text: str) -> None:
        """A robot the operator does not command needs them: an alert names it."""
        self._alerts.raise_alert("waiting", mirror.robot_id or "?", text, self._clock())

    def _send_route(self, route: RouteStarted, mirror: RobotMirror) -> None:
        """Send the supervisor's new route once, to the robot it was planned for."""
        cfg = self.config
        msg = mirror.new_route(
            self._route_ids(),
            route,
            approach_tolerance=cfg.approach_tolerance,
            goal_tolerance=cfg.goal_tolerance,
            yaw_tolerance=cfg.yaw_tolerance,
        )
        mirror.route_sent(self._link.send_to(mirror, Topic.ROUTE, msg))
        text = f"route {msg.route_id}: nodes {list(msg.node_ids)}"
        if mirror.supervisor.state is SupervisorState.WAITING_FOR_POSE:
            text += " (the goal alone: the robot plans to it from the position it finds)"
        self.log_for(mirror, "info", text)
        self._notices.route_sent(msg)
