"""What the station holds for ONE robot: its state, its supervisor and the mirror of its route.

Issue 14 (per-robot supervision): a station supervising a fleet keeps, for every robot, its own
`Supervisor` (queue, tour, pause, requests), its own `RouteMirror` (the robot owns its route;
shared/DESIGN.md "State has one owner") and the must-arrive state the station re-sends until
that robot receives it (the operator's stop intent, the planner configuration, the assisted-
teleoperation flag). `RobotMirror` is that bundle; `health` names the colour the map draws the
robot in. Plain Python (no Qt): the controller owns the link and the timers, and acts on it.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from dataclasses import dataclass

from base_station_app.robot_state import RobotState
from base_station_app.tablet_session import describe_task
from interbot_core.geometry import Pose2D
from interbot_core.route_mirror import RouteLost, RouteMirror
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import (
    Event,
    GoalReached,
    RequestAccepted,
    RequestDeclined,
    RequestShown,
    RequestTimedOut,
    RouteStarted,
    Supervisor,
    SupervisorConfig,
    TaskFinished,
    TaskStarted,
    TourStopReached,
)
from interbot_core.topics import RouteMsg, RouteProgress, StandingNotices, Status, Topic
from interbot_core.topological_map import TopologicalMap


class Health(enum.StrEnum):
    """How the map draws a robot (issue 14): the first that applies, in this order."""

    OFFLINE = "offline"  # liveliness token gone (or never seen)
    STOPPED = "stopped"  # its multiplexer reports the emergency-stop lock
    LOST = "lost"  # the localiser is lost, searching (or turning to), or has no pose yet
    DEGRADED = "degraded"  # the localiser (or the robot) says it is degraded
    OK = "ok"


@dataclass(frozen=True)
class RobotView:
    """What a view draws of one robot: a snapshot, so no widget holds robot state."""

    robot_id: str
    selected: bool
    health: Health
    pose: Pose2D | None  # last pose (any localiser state but unset); None: never localised
    plan: tuple[tuple[float, float], ...]  # the navigator's path for the route it drives
    task: str  # what it is doing, in words
    queued: int  # tasks waiting in its queue
    key: tuple[object, ...]  # changes whenever anything drawn changes


class RobotMirror:
    """One robot as the station knows it (see the module docstring)."""

    def __init__(
        self,
        robot_id: str | None,
        topo: TopologicalMap,
        planner: RoutePlanner,
        supervisor_config: SupervisorConfig,
    ) -> None:
        self.robot_id = robot_id  # None: the mirror of "no robot selected yet"
        self.online = False
        # The operator has commanded this robot (selected it) from this station: only then does
        # the station release its start latch; the stop goes to every robot regardless.
        self.commanded = False
        self.state = RobotState()
        self.supervisor = Supervisor(topo, planner, supervisor_config)
        self.route_mirror = RouteMirror()
        self.route: RouteMsg | None = None  # the route this station sent it and still mirrors
        self.route_index = 0
        self.goal_reached = False
        self.verdict_of: int | None = None  # route whose end the robot reported, if handled
        self.route_undelivered: int | None = None  # a route no robot received: end its task
        self.stop_assert_pending = True  # (re)assert the operator's stop intent to this robot
        self.stop_sent_at = -math.inf
        self.config_pending = True  # (re)send the planner config until this robot receives it
        self.assist_pending = True  # (re)send the station's assist flag likewise
        self.shown_request: tuple[int, RequestShown] | None = None
        self.pose_settling_until = -math.inf  # see task_commands.INITIAL_POSE_SETTLE_S
        # (robot stamp, text) of status lines logged here, so that a standing notice (also
        # sent as a status line, and in every snapshot) is logged once: the recent lines, and
        # the notices the robot holds (at most MAX_NOTICES).
        self.recent_lines: deque[tuple[float, str]] = deque(maxlen=256)
        self.notices_logged: set[tuple[float, str]] = set()

    def __repr__(self) -> str:
        return f"RobotMirror({self.robot_id!r}, online={self.online})"

    def connected(self, now: float) -> None:
        """The robot was selected, watched or came back: re-send must-arrive state; ask it."""
        self.config_pending = True
        self.assist_pending = True
        self.stop_assert_pending = True
        self.route_mirror.reconnected(now)

    # ------------------------------------------------------------------ its route (robot-owned)
    def new_route(
        self,
        route_id: int,
        route: RouteStarted,
        *,
        approach_tolerance: float,
        goal_tolerance: float,
        yaw_tolerance: float,
    ) -> RouteMsg:
        """The route message for the supervisor's new route; it becomes this robot's route."""
        ids = route.node_ids
        node_ids = tuple(n for n in ids if n is not None) if None not in ids else ()
        msg = RouteMsg(
            route_id,
            tuple((w.x, w.y, w.yaw) for w in route.waypoints),
            node_ids,
            approach_tolerance=approach_tolerance,
            goal_tolerance=goal_tolerance,
            yaw_tolerance=yaw_tolerance,
        )
        self.route = msg
        self.route_index = 0
        self.goal_reached = False
        return msg

    def route_sent(self, delivered: bool) -> None:
        """The route was sent once: mirrored if a robot received it, else lost at the next clock
        (never delivered later, when nobody may expect it)."""
        if self.route is None:
            return
        if delivered:
            self.route_mirror.started(self.route.route_id)
        else:
            self.route_undelivered = self.route.route_id

    def drop_route(self) -> int | None:
        """The station cancels its route; returns its id (None: none) for ``route_cancel``."""
        route_id = None if self.route is None else self.route.route_id
        self.route = None
        self.route_undelivered = None
        self.route_mirror.ended()
        return route_id

    def lose_route(self, lost: RouteLost) -> bool:
        """The robot no longer has our route; True when it was this station's current route."""
        self.route_mirror.ended()
        if self.route is None or self.route.route_id != lost.route_id:
            return False
        self.route = None
        return True

    def due_losses(self, now: float) -> list[RouteLost]:
        """Routes lost by ``now``: one nobody received, one the robot did not confirm in time."""
        losses = []
        if self.route_undelivered is not None:
            route_id, self.route_undelivered = self.route_undelivered, None
            losses.append(RouteLost(route_id, f"no robot received route {route_id}"))
        lost = self.route_mirror.check_timeout(now)
        if lost is not None:
            losses.append(lost)
        return losses

    def on_message(self, topic: Topic, message: object) -> tuple[RouteLost | None, list[Status]]:
        """A message from this robot: into its state and route mirror. Returns the route it
        lost and the status lines to log: a status line, or the standing notices not yet
        logged (a station that joined after they were said reads them from the snapshot)."""
        self.state.apply(topic, message)
        lost = None
        if topic is Topic.ROUTE_PROGRESS and isinstance(message, RouteProgress):
            lost = self.route_mirror.on_progress(message)
        fresh: list[Status] = []
        if topic is Topic.STATUS and isinstance(message, Status) and message.text:
            key = (message.stamp, message.text)
            if key not in self.notices_logged and key not in self.recent_lines:
                self.recent_lines.append(key)
                fresh.append(message)
        elif topic is Topic.NOTICES and isinstance(message, StandingNotices):
            held = set()
            for line in message.items:
                key = (line.stamp, line.text)
                held.add(key)
                if key not in self.notices_logged and key not in self.recent_lines:
                    fresh.append(line)
            self.notices_logged = held
        return lost, fresh

    def on_event(self, event: Event) -> None:
        """What a supervisor event changes in this mirror (the controller acts on the rest)."""
        if isinstance(event, TaskStarted):
            self.goal_reached = False
        elif isinstance(event, GoalReached | TourStopReached):
            self.goal_reached = True
        elif isinstance(event, TaskFinished | RequestAccepted | RequestDeclined | RequestTimedOut):
            self.shown_request = None

    def route_progress(self) -> RouteProgress | None:
        """The robot's newest report on OUR route (None: none, or about another route)."""
        progress, route = self.state.progress, self.route
        if progress is None or route is None or progress.route_id != route.route_id:
            return None
        self.route_index = progress.index
        return progress

    def verdict(self, progress: RouteProgress) -> bool:
        """True once per route when ``progress`` says the robot ended it (succeeded/aborted)."""
        if progress.state not in ("succeeded", "aborted") or progress.route_id == self.verdict_of:
            return False
        self.verdict_of = progress.route_id
        return True

    # ------------------------------------------------------------------ views
    @property
    def health(self) -> Health:
        state = self.state
        if not self.online:
            return Health.OFFLINE
        if state.estop_engaged:
            return Health.STOPPED
        loc = state.localisation
        if loc in ("lost", "unset", "searching", "turning"):
            return Health.LOST
        if loc == "degraded":
            return Health.DEGRADED
        return Health.OK

    def view(self, selected: bool, names: dict[int, str]) -> RobotView:
        """A snapshot for the map and the robot list."""
        msg = self.state.pose
        pose = None if msg is None or not msg.known else Pose2D(msg.x, msg.y, msg.yaw)
        plan = self.state.plan
        points = plan.points if plan is not None and self.route is not None else ()
        health = self.health
        task = self.task_text(names)
        queued = len(self.supervisor.queue)
        return RobotView(
            self.robot_id or "",
            selected,
            health,
            pose,
            points,
            task,
            queued,
            (selected, health, pose, id(plan), self.route is None, task, queued),
        )

    def task_text(self, names: dict[int, str]) -> str:
        task = self.supervisor.current_task
        foreign = self.route_mirror.foreign
        if task is None and foreign is not None:
            return f"route {foreign.route_id} (started before this station)"
        return "idle" if task is None else describe_task(task, names)

    def status_text(self, estop_latched: bool) -> str:
        sup = self.supervisor
        if estop_latched:
            return "emergency stop engaged"
        if not self.online:
            return "robot offline"
        foreign = self.route_mirror.foreign
        if sup.current_task is None and foreign is not None:
            return f"robot {foreign.state} on a route this station did not start; stop cancels it"
        text = str(sup.state).replace("_", " ")
        d = sup.distance_to_next_goal
        if d is not None:
            text += f", {d:.1f} m to the next goal"
        return text
