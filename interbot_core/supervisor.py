"""The Base Station's task logic: a queue of tasks driven by poses and time (supervisory control).

This is the goal-handling part of the thesis's ``clock()`` control loop (§5.3.6, Fig. 5.12) with
the tasks a user orders from the tablet or the station (§5.2.2): go to a room, guided tour (§6.2),
deliver a request between rooms, go home, go to a free pose. It is a pure state machine: the caller
feeds it ``update(now, pose)`` from its clock (``now`` in monotonic seconds, ``pose`` in the ``map``
frame or ``None`` while the robot is not localised) and user commands, and acts on the returned
:class:`Event` values (send a route to the robot, show a dialog, ...). No Qt, no wall clock.

Rules
-----
* Tasks run one at a time in queue order. A task starts only while the robot is localised
  (``pose`` not ``None``; thesis §5.2.2.1: no autonomous motion before the initial pose is set),
  or while it looks for a pose it had (below).
* A lost robot gets its next leg (issue 16). When a leg is due (a queued task, the tour's next
  stop, a delivery's next room) and the robot is not localised but had a pose and looks for it
  again (:class:`RobotCondition`: connected, not stopped, lost / searching / turning with a
  known pose), the leg is sent as the goal alone: a one-waypoint route to the goal node's pose
  (the last waypoint a planned route would have), which the robot's navigator drives to from
  the pose it finds (A* on its map). Not the topological route: it starts from the station's
  last pose, which after a kidnap is somewhere else, and the navigator drives every waypoint in
  order. The robot turns for that command while it searches (`look_around`) and drives only
  once localised; the station shows ``waiting_for_pose`` meanwhile and sends nothing more (the
  robot owns its route). Never at start-up (the robot never had a pose: thesis §5.2.2.1, the
  operator sets it or presses "Relocalise"), nor while disconnected, stopped, paused or held.
* Routes come from :class:`~interbot_core.route_planner.RoutePlanner` (Algorithms 2 and 5) and
  are sent whole to the robot with the tolerances of :class:`SupervisorConfig`. The robot judges
  progress (``robot_daemon.planning.goal_checker``: intermediate goals within
  ``approach_tolerance``, the final goal within ``goal_tolerance`` and ``yaw_tolerance``) and
  reports it; the supervisor mirrors the report (:meth:`Supervisor.robot_progress`,
  :meth:`Supervisor.robot_route_succeeded`, :meth:`Supervisor.robot_route_aborted`) and has no
  goal logic of its own, so the station and the robot cannot disagree on an arrival.
* Guided tour: the tour stops (ring buffer starting at the stop nearest the robot) are driven to
  one by one; at each the supervisor emits :class:`TourStopReached` and waits for
  :meth:`Supervisor.tour_resume` or :meth:`Supervisor.tour_end`.
* Delivery: drive to ``room`` (a node with ``requests: true``), show the request, wait up to
  ``request_timeout`` for :meth:`Supervisor.request_response`; on accept carry it to
  ``deliver_to``; on decline or time-out the task finishes unsuccessfully with the reason.
* Commands (``submit``, ``pause``, ``cancel``, ...) validate at once, raise
  :class:`TaskRejectedError` / :class:`SupervisorError` with an actionable message, and return the
  events that follow from them directly. Anything that needs a pose (planning a route, the tour
  order) or the time (request time-out) happens in :meth:`Supervisor.update`.
* ``pause()`` is a navigation lock (the thesis's pause lock on the speed multiplexer): it persists
  across tasks until ``resume()``; routes and time-outs keep running while paused.
"""

from __future__ import annotations

import enum
import logging
import math
from dataclasses import dataclass
from typing import Annotated, ClassVar

from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.route_planner import RoutePlanner, RoutePlanningError
from interbot_core.topics import Tolerance, YawTolerance
from interbot_core.topological_map import TopologicalMap, TopologicalMapError

logger = logging.getLogger(__name__)

DEFAULT_APPROACH_TOLERANCE = 1.0  # [m] intermediate goals
DEFAULT_GOAL_TOLERANCE = 0.5  # [m] thesis Table 6.3
DEFAULT_YAW_TOLERANCE = 0.1  # [rad] thesis Table 6.3


class SupervisorError(RuntimeError):
    """A command does not fit the current state (e.g. ``tour_resume`` while no tour waits)."""


class TaskRejectedError(ValueError):
    """A task cannot run on this map (unknown node, room without requests, no tour stops)."""


# ---------------------------------------------------------------------- tasks


@dataclass(frozen=True)
class GoTo:
    """Drive to topological node ``node`` and face its arrival yaw."""

    node: int


@dataclass(frozen=True)
class GuidedTour:
    """Visit every ``tour: true`` node, pausing at each until the user resumes or ends the tour."""


@dataclass(frozen=True)
class Delivery:
    """Take ``request_text`` to ``room`` (requests allowed), then on acceptance to ``deliver_to``."""

    request_text: str
    room: int
    deliver_to: int


@dataclass(frozen=True)
class GoHome:
    """Drive to the map's home node."""


@dataclass(frozen=True)
class GoToPose:
    """Drive straight to a free pose in the ``map`` frame (no topological route)."""

    pose: Pose2D


Task = GoTo | GuidedTour | Delivery | GoHome | GoToPose


# ---------------------------------------------------------------------- events


@dataclass(frozen=True)
class TaskStarted:
    task: Task


@dataclass(frozen=True)
class TaskFinished:
    task: Task
    ok: bool
    reason: str


@dataclass(frozen=True)
class QueueChanged:
    queue: tuple[Task, ...]


@dataclass(frozen=True)
class RouteStarted:
    """Send the whole route to the robot. ``node_ids[i]`` is the node of ``waypoints[i]``
    (``None`` for a free pose); ``final_node`` is the goal node (``None`` for a free pose)."""

    waypoints: tuple[Pose2D, ...]
    node_ids: tuple[int | None, ...]
    final_node: int | None


@dataclass(frozen=True)
class RouteCancelled:
    """Tell the robot to drop its route (task cancelled or tour ended while driving)."""

    reason: str


@dataclass(frozen=True)
class IntermediateGoalReached:
    node: int | None
    index: int  # waypoint index in the current route


@dataclass(frozen=True)
class GoalReached:
    node: int | None
    pose: Pose2D  # the goal pose that was reached


@dataclass(frozen=True)
class PauseNavigation:
    paused: bool


@dataclass(frozen=True)
class TourStopReached:
    node: int
    info: str
    name: str
    visited: tuple[int, ...]
    next_stop: int | None  # None at the last stop


@dataclass(frozen=True)
class RequestShown:
    text: str
    room: int
    deliver_to: int
    deadline: float  # [s] same clock as ``now``


@dataclass(frozen=True)
class RequestAccepted:
    text: str
    room: int
    deliver_to: int


@dataclass(frozen=True)
class RequestDeclined:
    text: str
    room: int
    deliver_to: int


@dataclass(frozen=True)
class RequestTimedOut:
    text: str
    room: int
    deliver_to: int


Event = (
    TaskStarted
    | TaskFinished
    | QueueChanged
    | RouteStarted
    | RouteCancelled
    | IntermediateGoalReached
    | GoalReached
    | PauseNavigation
    | TourStopReached
    | RequestShown
    | RequestAccepted
    | RequestDeclined
    | RequestTimedOut
)


# ---------------------------------------------------------------------- configuration and state


class SupervisorConfig(schema.Declared, frozen=True):
    """Goal tolerances (thesis Table 6.3) sent with each route (declared as the route message
    declares them), and the request time-out; a bad value raises ValueError naming it."""

    ROOT: ClassVar[str] = "SupervisorConfig"
    ERROR: ClassVar[type[Exception]] = ValueError

    approach_tolerance: Tolerance = DEFAULT_APPROACH_TOLERANCE  # intermediate goals
    goal_tolerance: Tolerance = DEFAULT_GOAL_TOLERANCE  # final goal position
    yaw_tolerance: YawTolerance = DEFAULT_YAW_TOLERANCE  # final goal heading
    # wait for an answer at the request room
    request_timeout: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "s"})] = 120.0


@dataclass(frozen=True)
class RobotCondition:
    """What the station knows of its robot besides a localised pose (`Supervisor.update`).

    ``finding``: the robot reports lost, searching or turning with the pose it had (the pose
    message's ``known``): it was localised and looks for itself again. False at start-up, when
    it never had a pose (thesis §5.2.2.1) and while it is localised.
    """

    connected: bool
    stopped: bool  # emergency stop engaged (the robot's report or the operator's intent)
    finding: bool

    @property
    def may_take_a_leg(self) -> bool:
        """Whether a leg may be sent to it while it is not localised."""
        return self.connected and not self.stopped and self.finding


class SupervisorState(enum.StrEnum):
    IDLE = "idle"
    WAITING_FOR_POSE = "waiting_for_pose"
    NAVIGATING = "navigating"
    PAUSED = "paused"  # navigating, but the pause lock is on
    AT_TOUR_STOP = "at_tour_stop"
    AWAITING_RESPONSE = "awaiting_response"
    QUEUE_HELD = "queue_held"  # after an emergency stop: waiting tasks wait for the operator


class _Phase(enum.Enum):
    NEED_ROUTE = enum.auto()  # a goal is set, the route is planned at the next localised update
    FOLLOWING = enum.auto()
    AT_TOUR_STOP = enum.auto()
    AWAITING_RESPONSE = enum.auto()


# ---------------------------------------------------------------------- the supervisor


class Supervisor:
    """Queue of tasks, run in order against poses and time (see the module docstring)."""

    def __init__(
        self,
        topo: TopologicalMap,
        planner: RoutePlanner | None = None,
        config: SupervisorConfig | None = None,
    ) -> None:
        self.topo = topo
        self.planner = planner if planner is not None else RoutePlanner(topo)
        if self.planner.topo is not topo:
            raise ValueError("the RoutePlanner was built for a different topological map")
        self.config = config if config is not None else SupervisorConfig()
        self._queue: list[Task] = []
        self._paused = False
        self._held = False
        self._pose: Pose2D | None = None
        self._localized = False
        self._reset_task()

    def _reset_task(self) -> None:
        self._task: Task | None = None
        self._phase: _Phase | None = None
        self._goal_node: int | None = None
        self._goal_pose: Pose2D | None = None
        self._route: RouteStarted | None = None
        self._blind = False  # the route went to a robot that was not localised (goal alone)
        self._index = 0  # the waypoint the robot reports heading for
        self._tour_stops: tuple[int, ...] = ()
        self._visited: list[int] = []
        self._delivering = False  # Delivery: False on the way to the room, True after accept
        self._deadline: float | None = None

    # ------------------------------------------------------------------ read-only state

    @property
    def current_task(self) -> Task | None:
        return self._task

    @property
    def state(self) -> SupervisorState:
        if self._task is None:
            if self._queue and self._held:
                return SupervisorState.QUEUE_HELD
            if self._queue and not self._localized:
                return SupervisorState.WAITING_FOR_POSE
            return SupervisorState.IDLE
        if self._phase is _Phase.AT_TOUR_STOP:
            return SupervisorState.AT_TOUR_STOP
        if self._phase is _Phase.AWAITING_RESPONSE:
            return SupervisorState.AWAITING_RESPONSE
        if self._phase is _Phase.NEED_ROUTE and not self._localized:
            return SupervisorState.WAITING_FOR_POSE
        if self._blind and not self._localized:
            return SupervisorState.WAITING_FOR_POSE  # the goal is sent; the robot finds itself
        return SupervisorState.PAUSED if self._paused else SupervisorState.NAVIGATING

    @property
    def queue(self) -> tuple[Task, ...]:
        """Tasks waiting to start, in order (the current task is not included)."""
        return tuple(self._queue)

    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def held(self) -> bool:
        """True while waiting tasks may not start (after an emergency stop)."""
        return self._held

    @property
    def pose(self) -> Pose2D | None:
        """The last known pose (kept while localisation is lost)."""
        return self._pose

    @property
    def current_route(self) -> RouteStarted | None:
        """The route last sent to the robot for the current task (kept after arrival)."""
        return self._route

    @property
    def route_index(self) -> int | None:
        """Index into ``current_route.waypoints`` of the goal being driven to (the robot's word)."""
        return None if self._route is None else self._index

    @property
    def current_goal_node(self) -> int | None:
        """The node the current leg ends at (``None`` for a free pose or no task)."""
        return self._goal_node

    @property
    def tour_stops(self) -> tuple[int, ...]:
        """All stops of the running tour in visiting order (empty without a tour)."""
        return self._tour_stops

    @property
    def visited_tour_stops(self) -> tuple[int, ...]:
        return tuple(self._visited)

    @property
    def next_tour_stop(self) -> int | None:
        """The first stop of the running tour not yet visited (the one being driven to)."""
        remaining = self._tour_stops[len(self._visited) :]
        return remaining[0] if remaining else None

    @property
    def distance_to_next_goal(self) -> float | None:
        """Straight-line distance from the last pose to the current target [m]."""
        if self._route is None or self._pose is None or self._phase is not _Phase.FOLLOWING:
            return None
        if self._blind and not self._localized:
            return None  # from a pose the robot no longer vouches for
        return self._pose.distance_to(self._route.waypoints[self._index])

    # ------------------------------------------------------------------ commands

    def submit(self, task: Task) -> list[Event]:
        """Validate ``task`` against the map and append it to the queue."""
        self._validate(task)
        self._queue.append(task)
        logger.info("task queued: %s (queue length %d)", task, len(self._queue))
        return [QueueChanged(self.queue)]

    def pause(self) -> list[Event]:
        """Engage the pause lock (navigation stops, the task is kept)."""
        if self._paused:
            return []
        self._paused = True
        return [PauseNavigation(True)]

    def resume(self) -> list[Event]:
        """Release the pause lock."""
        if not self._paused:
            return []
        self._paused = False
        return [PauseNavigation(False)]

    def hold_queue(self) -> list[Event]:
        """Start no waiting task until `release_queue` (the operator's "Resume queue")."""
        if self._held:
            return []
        self._held = True
        return [QueueChanged(self.queue)]

    def release_queue(self) -> list[Event]:
        if not self._held:
            return []
        self._held = False
        return [QueueChanged(self.queue)]

    def cancel(self) -> list[Event]:
        """Abort the current task (the queue is untouched; the next task starts on update)."""
        if self._task is None:
            return []
        return self._finish(False, "cancelled by the user", cancel_route=True)

    def clear_queue(self) -> list[Event]:
        """Drop every waiting task (the current task is untouched)."""
        if not self._queue:
            return []
        self._queue.clear()
        return [QueueChanged(self.queue)]

    def reorder(self, from_index: int, to_index: int) -> list[Event]:
        """Move the waiting task at ``from_index`` to ``to_index`` (0 runs next)."""
        self._check_index(from_index)
        self._check_index(to_index)
        task = self._queue.pop(from_index)
        self._queue.insert(to_index, task)
        return [QueueChanged(self.queue)]

    def remove(self, index: int) -> list[Event]:
        """Drop the waiting task at ``index``."""
        self._check_index(index)
        del self._queue[index]
        return [QueueChanged(self.queue)]

    def tour_resume(self) -> list[Event]:
        """Leave the tour stop the robot waits at: drive to the next one, or finish the tour."""
        if self._phase is not _Phase.AT_TOUR_STOP:
            raise SupervisorError(f"no tour is waiting at a stop (state: {self.state})")
        next_stop = self.next_tour_stop
        if next_stop is None:
            n = len(self._tour_stops)
            return self._finish(True, f"tour complete: visited all {n} stops")
        self._set_goal(next_stop)
        return []

    def tour_end(self) -> list[Event]:
        """End the running guided tour (at a stop or on the way)."""
        if not isinstance(self._task, GuidedTour):
            raise SupervisorError(f"no guided tour is running (state: {self.state})")
        visited, n = len(self._visited), len(self._tour_stops)
        return self._finish(
            True, f"tour ended by the user after {visited} of {n} stops", cancel_route=True
        )

    def request_response(self, accepted: bool) -> list[Event]:
        """Answer the request shown at the room: accept (deliver it) or decline (report back)."""
        task = self._task
        if self._phase is not _Phase.AWAITING_RESPONSE or not isinstance(task, Delivery):
            raise SupervisorError(f"no request is waiting for a response (state: {self.state})")
        self._deadline = None
        if accepted:
            self._delivering = True
            self._set_goal(task.deliver_to)
            return [RequestAccepted(task.request_text, task.room, task.deliver_to)]
        events: list[Event] = [RequestDeclined(task.request_text, task.room, task.deliver_to)]
        events += self._finish(False, f"request declined at {self._name(task.room)}")
        return events

    def robot_progress(self, index: int) -> list[Event]:
        """The robot reports heading for waypoint ``index`` of the current route: every waypoint
        before it was reached (one `IntermediateGoalReached` each, in order)."""
        route = self._route
        if self._phase is not _Phase.FOLLOWING or route is None:
            return []
        if isinstance(index, bool) or not isinstance(index, int) or index < 0:
            raise ValueError(f"route progress index must be an integer >= 0, got {index!r}")
        last = len(route.waypoints) - 1
        index = min(index, last)
        events: list[Event] = [
            IntermediateGoalReached(route.node_ids[i], i) for i in range(self._index, index)
        ]
        self._index = max(self._index, index)
        return events

    def robot_route_succeeded(self, now: float) -> list[Event]:
        """The robot reports that it reached the final goal of the current route (judged on the
        robot with its own pose and the route's tolerances): the goal is reached."""
        if self._phase is not _Phase.FOLLOWING or self._route is None:
            return []
        events = self.robot_progress(len(self._route.waypoints) - 1)
        self._arrived(now, events)
        return events

    def robot_route_aborted(self, reason: str) -> list[Event]:
        """The robot gave up the current route (blocked, ...): the task fails with its reason."""
        if self._phase is not _Phase.FOLLOWING or self._task is None:
            return []
        return self._finish(False, f"robot aborted the route: {reason}")

    # ------------------------------------------------------------------ the clock

    def update(
        self, now: float, pose: Pose2D | None, robot: RobotCondition | None = None
    ) -> list[Event]:
        """One control-loop step (thesis ``clock()``): start tasks, plan routes, time out.

        ``pose`` is the robot pose in the ``map`` frame, or ``None`` while it is not localised
        (a running route keeps its state). Tasks and legs then wait, unless ``robot`` says it
        looks for a pose it had and may take a leg: the goal alone is sent (module docstring).
        """
        if not math.isfinite(now):
            raise ValueError(f"now must be a finite time [s], got {now!r}")
        self._localized = pose is not None
        if pose is not None:
            self._pose = pose
            self._blind = False
        blind = (
            pose is None
            and robot is not None
            and robot.may_take_a_leg
            and not self._paused
            and not self._held
        )
        events: list[Event] = []
        # A task may finish within this step (goal already reached, time-out), so the next one
        # may start at once; each pass either leaves a task running or consumes one from the queue.
        for _ in range(len(self._queue) + 1):
            if self._task is None:
                if not self._queue or self._held:
                    break
                if pose is None and not blind:
                    break
                # A tour's order starts at the stop nearest the robot: when it is lost, nearest
                # the last pose the station saw (none: the tour waits for a pose).
                where = pose if pose is not None else self._pose
                if where is None and isinstance(self._queue[0], GuidedTour):
                    break
                self._start_next(where, events)
            if self._phase is _Phase.NEED_ROUTE and pose is not None:
                self._start_route(pose, events)
            elif self._phase is _Phase.NEED_ROUTE and blind:
                self._send_goal_alone(events)
            if (
                self._phase is _Phase.AWAITING_RESPONSE
                and self._deadline is not None
                and now >= self._deadline
            ):
                self._time_out(events)
            if self._task is not None:
                break
        return events

    # ------------------------------------------------------------------ internals

    def _validate(self, task: Task) -> None:
        try:
            if isinstance(task, GoTo):
                self.topo.node(task.node, "goal")
            elif isinstance(task, GuidedTour):
                if not self.topo.tour_nodes():
                    raise TaskRejectedError(
                        f"no guided tour: no node of {self.topo.source} has 'tour: true'"
                    )
            elif isinstance(task, Delivery):
                if not isinstance(task.request_text, str) or not task.request_text.strip():
                    raise TaskRejectedError("a delivery needs a non-empty request text")
                room = self.topo.node(task.room, "request room")
                self.topo.node(task.deliver_to, "delivery target")
                if not room.requests:
                    allowed = ", ".join(f"{n.id} ({n.name})" for n in self.topo.request_nodes())
                    raise TaskRejectedError(
                        f"node {room.id} ({room.name}) does not take requests "
                        f"('requests: false' in {self.topo.source}); "
                        f"rooms that do: {allowed or 'none'}"
                    )
            elif isinstance(task, GoToPose):
                if not isinstance(task.pose, Pose2D):
                    raise TaskRejectedError(f"GoToPose needs a Pose2D, got {task.pose!r}")
            elif not isinstance(task, GoHome):
                raise TaskRejectedError(f"unknown task type {type(task).__name__}")
        except TopologicalMapError as exc:
            raise TaskRejectedError(str(exc)) from exc

    def _check_index(self, index: int) -> None:
        if not 0 <= index < len(self._queue):
            raise SupervisorError(
                f"queue index {index} out of range (queue holds {len(self._queue)} tasks)"
            )

    def _name(self, node_id: int) -> str:
        return f"node {node_id} ({self.topo.nodes[node_id].name})"

    def _set_goal(self, node_id: int | None, pose: Pose2D | None = None) -> None:
        self._goal_node = node_id
        self._goal_pose = pose
        self._phase = _Phase.NEED_ROUTE

    def _start_next(self, pose: Pose2D | None, events: list[Event]) -> None:
        task = self._queue.pop(0)
        self._task = task
        events += [TaskStarted(task), QueueChanged(self.queue)]
        logger.info("task started: %s", task)
        if isinstance(task, GoTo):
            self._set_goal(task.node)
        elif isinstance(task, GoHome):
            self._set_goal(self.topo.home_id)
        elif isinstance(task, GoToPose):
            self._set_goal(None, task.pose)
        elif isinstance(task, Delivery):
            self._set_goal(task.room)
        else:
            assert pose is not None  # update() starts a tour only with a pose
            self._tour_stops = tuple(self.planner.tour_order(pose))
            self._set_goal(self._tour_stops[0])

    def _start_route(self, pose: Pose2D, events: list[Event]) -> None:
        if self._goal_node is None:
            if self._goal_pose is None:  # pragma: no cover - _set_goal always sets one
                raise AssertionError("a goal without node or pose")
            waypoints: tuple[Pose2D, ...] = (self._goal_pose,)
            node_ids: tuple[int | None, ...] = (None,)
        else:
            try:
                route = self.planner.plan(
                    pose, self._goal_node, skip_start_within=self.config.approach_tolerance
                )
            except RoutePlanningError as exc:
                events += self._finish(False, str(exc))
                return
            waypoints, node_ids = route.waypoints, route.node_ids
        self._route = RouteStarted(waypoints, node_ids, self._goal_node)
        self._index = 0
        self._phase = _Phase.FOLLOWING
        events.append(self._route)

    def _send_goal_alone(self, events: list[Event]) -> None:
        """The leg to a robot that is not localised: its goal, which it plans to from the pose
        it finds (module docstring)."""
        node = self._goal_node
        goal = self.topo.nodes[node].pose if node is not None else self._goal_pose
        if goal is None:  # pragma: no cover - _set_goal always sets one
            raise AssertionError("a goal without node or pose")
        self._route = RouteStarted((goal,), (node,), node)
        self._index = 0
        self._phase = _Phase.FOLLOWING
        self._blind = True
        logger.info("robot not localised: sent it the goal alone (%s)", goal)
        events.append(self._route)

    def _arrived(self, now: float, events: list[Event]) -> None:
        task, node = self._task, self._goal_node
        target = self._route.waypoints[-1] if self._route is not None else None
        if isinstance(task, GuidedTour) and node is not None:
            self._visited.append(node)
            self._phase = _Phase.AT_TOUR_STOP
            info = self.topo.nodes[node]
            events.append(
                TourStopReached(
                    node, info.info, info.name, tuple(self._visited), self.next_tour_stop
                )
            )
            return
        if target is not None:
            events.append(GoalReached(node, target))
        if isinstance(task, Delivery) and not self._delivering:
            self._phase = _Phase.AWAITING_RESPONSE
            self._deadline = now + self.config.request_timeout
            events.append(
                RequestShown(task.request_text, task.room, task.deliver_to, self._deadline)
            )
        elif isinstance(task, Delivery):
            events += self._finish(True, f"request delivered to {self._name(task.deliver_to)}")
        elif node is not None:
            events += self._finish(True, f"reached {self._name(node)}")
        else:
            events += self._finish(True, f"reached pose {target}")

    def _time_out(self, events: list[Event]) -> None:
        task = self._task
        if not isinstance(task, Delivery):  # pragma: no cover - only deliveries wait for answers
            raise AssertionError("awaiting a response without a delivery")
        events.append(RequestTimedOut(task.request_text, task.room, task.deliver_to))
        events += self._finish(
            False,
            f"no response within {self.config.request_timeout:g} s at {self._name(task.room)}",
        )

    def _finish(self, ok: bool, reason: str, cancel_route: bool = False) -> list[Event]:
        task = self._task
        if task is None:  # pragma: no cover - callers check
            return []
        events: list[Event] = []
        if cancel_route and self._phase is _Phase.FOLLOWING:
            events.append(RouteCancelled(reason))
        events.append(TaskFinished(task, ok, reason))
        logger.info("task finished: %s ok=%s (%s)", task, ok, reason)
        self._reset_task()
        return events
