"""Tests for interbot_core.supervisor, driven by a synthetic robot moving along the routes.

The supervisor has no goal logic of its own: the robot judges progress and reports it. The
synthetic robot here judges with the robot's own rule (`robot_daemon.planning.goal_checker`,
the route's tolerances) and reports as the daemon does (`robot_progress`, then
`robot_route_succeeded`)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from interbot_core.geometry import Pose2D, wrap_angle
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import (
    Delivery,
    Event,
    GoalReached,
    GoHome,
    GoTo,
    GoToPose,
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
    SupervisorConfig,
    SupervisorError,
    SupervisorState,
    TaskFinished,
    TaskRejectedError,
    TaskStarted,
    TourStopReached,
)
from interbot_core.topological_map import TopologicalMap, load_topological_map
from robot_daemon.planning.goal_checker import final_goal_reached, next_goal_index

FIXTURE = Path(__file__).parent / "data" / "tiny_topo.yaml"
DT = 0.1  # [s] clock period of the synthetic control loop
STEP = 0.4  # [m] distance moved per tick
TURN = 0.3  # [rad] rotation per tick


class Sim:
    """A robot that drives straight to each target of the route it was sent, judges its progress
    with the robot's goal checker and reports it to the supervisor."""

    def __init__(self, sup: Supervisor, pose: Pose2D | None) -> None:
        self.sup = sup
        self.pose = pose
        self.now = 0.0
        self.events: list[Event] = []
        self.times: list[float] = []  # [s] when each event was returned
        self._route: RouteStarted | None = None
        self._index = 0

    def tick(self, localized: bool = True) -> list[Event]:
        self.now += DT
        events = self.sup.update(self.now, self.pose if localized else None)
        if localized:
            events += self.robot_reports()
        self.events += events
        self.times += [self.now] * len(events)
        return events

    def robot_reports(self) -> list[Event]:
        """What the robot says about the route it drives (nothing without a route)."""
        route, pose, cfg = self.sup.current_route, self.pose, self.sup.config
        if route is None or pose is None:
            return []
        if route is not self._route:
            self._route, self._index = route, 0
        goals = route.waypoints
        self._index = next_goal_index(goals, self._index, pose, cfg.approach_tolerance)
        events = self.sup.robot_progress(self._index)
        last = len(goals) - 1
        if self._index == last and final_goal_reached(
            pose, goals[last], cfg.goal_tolerance, cfg.yaw_tolerance
        ):
            events += self.sup.robot_route_succeeded(self.now)
        return events

    def move_to(self, target: Pose2D, face_goal: bool) -> None:
        assert self.pose is not None
        while (d := self.pose.distance_to(target)) > 1e-9:
            heading = math.atan2(target.y - self.pose.y, target.x - self.pose.x)
            s = min(STEP, d)
            self.pose = Pose2D(
                self.pose.x + s * math.cos(heading), self.pose.y + s * math.sin(heading), heading
            )
            self.tick()
        if face_goal:
            while (err := wrap_angle(target.yaw - self.pose.yaw)) != 0.0:
                turn = max(-TURN, min(TURN, err))
                self.pose = Pose2D(self.pose.x, self.pose.y, self.pose.yaw + turn)
                self.tick()

    def follow_route(self) -> None:
        """Drive the current route waypoint by waypoint until the supervisor stops navigating."""
        for _ in range(100):
            route, index = self.sup.current_route, self.sup.route_index
            if self.sup.state not in (SupervisorState.NAVIGATING, SupervisorState.PAUSED):
                return
            assert route is not None and index is not None
            last = index == len(route.waypoints) - 1
            self.move_to(route.waypoints[index], face_goal=last)
        raise AssertionError("route not finished")

    def time_of(self, kind: type) -> float:
        return next(t for t, e in zip(self.times, self.events, strict=True) if isinstance(e, kind))

    def of(self, kind: type) -> list[Event]:
        return [e for e in self.events if isinstance(e, kind)]


@pytest.fixture
def topo() -> TopologicalMap:
    return load_topological_map(FIXTURE)


@pytest.fixture
def sup(topo: TopologicalMap) -> Supervisor:
    return Supervisor(topo, RoutePlanner(topo), SupervisorConfig())


def test_single_goal_with_intermediate_goals(sup: Supervisor, topo: TopologicalMap) -> None:
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    assert sup.submit(GoTo(3)) == [QueueChanged((GoTo(3),))]
    events = sim.tick()
    route = RouteStarted(
        (Pose2D(10.0, 0.0, 0.0), Pose2D(20.0, 0.0, math.pi / 2), topo.node(3).pose),
        (1, 2, 3),
        3,
    )
    # node 0 is under the robot: the route starts at node 1 (plan() drops it)
    assert events == [TaskStarted(GoTo(3)), QueueChanged(()), route]
    assert sup.state is SupervisorState.NAVIGATING and sup.current_task == GoTo(3)
    assert sup.distance_to_next_goal == pytest.approx(10.0)
    sim.follow_route()
    assert sim.of(IntermediateGoalReached) == [
        IntermediateGoalReached(1, 0),
        IntermediateGoalReached(2, 1),
    ]
    assert sim.of(GoalReached) == [GoalReached(3, topo.node(3).pose)]
    assert sim.of(TaskFinished) == [TaskFinished(GoTo(3), True, "reached node 3 (Bar)")]
    assert sup.state is SupervisorState.IDLE and sup.current_task is None


def test_final_goal_needs_position_and_orientation(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(19.0, 9.0, 0.0))
    sup.submit(GoTo(3))  # (20, 10), yaw pi/2
    sim.tick()
    sim.pose = Pose2D(20.0, 9.4, 0.0)  # 0.6 m away, wrong yaw
    assert not any(isinstance(e, GoalReached) for e in sim.tick())
    sim.pose = Pose2D(20.0, 9.6, 0.0)  # inside 0.5 m, still wrong yaw
    assert not any(isinstance(e, GoalReached) for e in sim.tick())
    sim.pose = Pose2D(20.0, 9.6, math.pi / 2 - 0.15)  # yaw 0.15 rad off
    assert not any(isinstance(e, GoalReached) for e in sim.tick())
    sim.pose = Pose2D(20.0, 9.6, math.pi / 2 - 0.05)
    events = sim.tick()
    assert [type(e) for e in events] == [GoalReached, TaskFinished]


def test_guided_tour_pause_resume_end_with_visited_tracking(
    sup: Supervisor, topo: TopologicalMap
) -> None:
    sim = Sim(sup, Pose2D(0.2, 0.0, 0.0))  # on node 0, facing its yaw
    sup.submit(GuidedTour())
    events = sim.tick()
    assert sup.tour_stops == (0, 1, 2, 4)
    assert events[-1] == TourStopReached(0, "Welcome", "Entrance", (0,), 1)
    assert sup.state is SupervisorState.AT_TOUR_STOP
    assert sup.visited_tour_stops == (0,) and sup.next_tour_stop == 1
    with pytest.raises(SupervisorError, match="no request is waiting"):
        sup.request_response(True)
    for _ in range(3):  # waits at the stop, however long
        assert sim.tick() == []
    assert sup.tour_resume() == []
    events = sim.tick()
    assert [type(e) for e in events] == [RouteStarted]
    assert sup.state is SupervisorState.NAVIGATING
    with pytest.raises(SupervisorError, match="no tour is waiting at a stop"):
        sup.tour_resume()
    sim.follow_route()
    assert sim.of(TourStopReached)[-1] == TourStopReached(1, "Lab A info", "Lab A", (0, 1), 2)
    sup.tour_resume()
    sim.tick()
    sim.follow_route()
    assert sup.visited_tour_stops == (0, 1, 2) and sup.next_tour_stop == 4
    assert sim.of(GoalReached) == []  # tour stops report TourStopReached only
    assert sup.tour_end() == [
        TaskFinished(GuidedTour(), True, "tour ended by the user after 3 of 4 stops")
    ]
    assert sup.state is SupervisorState.IDLE and sup.visited_tour_stops == ()


def test_guided_tour_completes_after_last_stop(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(10.0, 10.0, math.pi))  # on node 4, tour order 4, 0, 1, 2
    sup.submit(GuidedTour())
    sim.tick()
    for _ in range(3):
        assert sup.state is SupervisorState.AT_TOUR_STOP
        sup.tour_resume()
        sim.tick()
        sim.follow_route()
    assert [e.node for e in sim.of(TourStopReached)] == [4, 0, 1, 2]
    assert sim.of(TourStopReached)[-1].next_stop is None
    assert sup.tour_resume() == [
        TaskFinished(GuidedTour(), True, "tour complete: visited all 4 stops")
    ]


def test_tour_end_while_driving_cancels_the_route(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(5.0, 0.0, 0.0))
    sup.submit(GuidedTour())
    sim.tick()
    assert sup.state is SupervisorState.NAVIGATING
    events = sup.tour_end()
    assert [type(e) for e in events] == [RouteCancelled, TaskFinished]


def _deliver_to_room(sup: Supervisor) -> Sim:
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(Delivery("a stapler", room=4, deliver_to=2))
    sim.tick()
    sim.follow_route()
    assert sup.state is SupervisorState.AWAITING_RESPONSE
    return sim


def test_delivery_accepted_is_carried_to_target(sup: Supervisor, topo: TopologicalMap) -> None:
    sim = _deliver_to_room(sup)
    shown = sim.of(RequestShown)
    assert shown == [
        RequestShown("a stapler", 4, 2, pytest.approx(sim.time_of(RequestShown) + 120.0))
    ]
    assert sim.of(GoalReached) == [GoalReached(4, topo.node(4).pose)]
    assert sup.request_response(True) == [RequestAccepted("a stapler", 4, 2)]
    sim.tick()
    assert sim.events[-1] == sup.current_route and sup.current_route is not None
    assert sup.current_route.final_node == 2
    sim.follow_route()
    assert sim.of(TaskFinished) == [
        TaskFinished(Delivery("a stapler", 4, 2), True, "request delivered to node 2 (Office B)")
    ]


def test_delivery_declined_reports_back(sup: Supervisor) -> None:
    _deliver_to_room(sup)
    assert sup.request_response(False) == [
        RequestDeclined("a stapler", 4, 2),
        TaskFinished(Delivery("a stapler", 4, 2), False, "request declined at node 4 (Store)"),
    ]
    assert sup.state is SupervisorState.IDLE


def test_delivery_times_out(topo: TopologicalMap) -> None:
    sup = Supervisor(topo, config=SupervisorConfig(request_timeout=30.0))
    sim = _deliver_to_room(sup)
    deadline = sim.time_of(RequestShown) + 30.0
    assert [e.deadline for e in sim.of(RequestShown)] == [pytest.approx(deadline)]  # type: ignore[attr-defined]
    assert sup.update(deadline - 0.01, sim.pose) == []
    assert sup.update(deadline, sim.pose) == [
        RequestTimedOut("a stapler", 4, 2),
        TaskFinished(
            Delivery("a stapler", 4, 2), False, "no response within 30 s at node 4 (Store)"
        ),
    ]
    with pytest.raises(SupervisorError):
        sup.request_response(True)


def test_requests_only_at_request_rooms(sup: Supervisor) -> None:
    with pytest.raises(TaskRejectedError, match=r"node 2 \(Office B\) does not take requests"):
        sup.submit(Delivery("x", room=2, deliver_to=0))
    with pytest.raises(TaskRejectedError, match="rooms that do: 1 \\(Lab A\\), 4 \\(Store\\)"):
        sup.submit(Delivery("x", room=3, deliver_to=0))
    with pytest.raises(TaskRejectedError, match="delivery target 9 is not a node"):
        sup.submit(Delivery("x", room=1, deliver_to=9))
    with pytest.raises(TaskRejectedError, match="non-empty request text"):
        sup.submit(Delivery("  ", room=1, deliver_to=0))
    with pytest.raises(TaskRejectedError, match=r"goal 42 is not a node of .*tiny_topo.yaml"):
        sup.submit(GoTo(42))
    assert sup.queue == ()


def test_pause_resume_cancel(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(GoTo(2))
    sup.submit(GoHome())
    sim.tick()
    assert sup.pause() == [PauseNavigation(True)]
    assert sup.pause() == []
    assert sup.state is SupervisorState.PAUSED and sup.paused
    sim.move_to(Pose2D(10.0, 0.0, 0.0), face_goal=False)  # e.g. pushed; progress still tracked
    assert sup.route_index == 1
    assert sup.resume() == [PauseNavigation(False)]
    assert sup.resume() == []
    assert sup.state is SupervisorState.NAVIGATING
    assert sup.cancel() == [
        RouteCancelled("cancelled by the user"),
        TaskFinished(GoTo(2), False, "cancelled by the user"),
    ]
    assert sup.current_task is None and sup.current_route is None
    events = sim.tick()  # the next task starts: home is node 0
    assert events[0] == TaskStarted(GoHome())
    assert isinstance(events[-1], RouteStarted) and events[-1].final_node == 0
    sup.cancel()
    assert sup.cancel() == []


def test_queue_order_and_reorder(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(5.0, 0.0, 0.0))
    for task in (GoTo(1), GoTo(2), GoTo(4)):
        sup.submit(task)
    assert sup.reorder(2, 0) == [QueueChanged((GoTo(4), GoTo(1), GoTo(2)))]
    assert sup.remove(1) == [QueueChanged((GoTo(4), GoTo(2)))]
    with pytest.raises(SupervisorError, match="queue index 5 out of range"):
        sup.reorder(5, 0)
    sup.submit(GoTo(1))
    started: list[Event] = []
    for _ in range(3):
        sim.tick()
        started += sim.of(TaskStarted)[len(started) :]
        sim.follow_route()
    assert [e.task for e in sim.of(TaskStarted)] == [GoTo(4), GoTo(2), GoTo(1)]
    assert [e.ok for e in sim.of(TaskFinished)] == [True, True, True]
    assert sup.clear_queue() == []
    sup.submit(GoTo(0))
    sup.submit(GoTo(3))
    sim.tick()
    assert sup.clear_queue() == [QueueChanged(())]
    assert sup.current_task == GoTo(0)


def test_tasks_wait_for_a_pose(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(0.2, 0.0, 0.0))
    sup.submit(GoTo(1))
    assert sim.tick(localized=False) == []
    assert sup.state is SupervisorState.WAITING_FOR_POSE and sup.queue == (GoTo(1),)
    assert sup.distance_to_next_goal is None
    events = sim.tick()
    assert [type(e) for e in events] == [TaskStarted, QueueChanged, RouteStarted]
    # a tour leg planned after resume also waits for localisation
    sup.cancel()
    sup.submit(GuidedTour())
    sim.tick()
    assert sup.state is SupervisorState.AT_TOUR_STOP  # on node 0
    sup.tour_resume()
    assert sim.tick(localized=False) == []
    assert sup.state is SupervisorState.WAITING_FOR_POSE
    assert [type(e) for e in sim.tick()] == [RouteStarted]


def test_losing_the_pose_keeps_the_route(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(GoTo(2))
    sim.tick()
    route = sup.current_route
    assert sim.tick(localized=False) == []
    assert sup.state is SupervisorState.NAVIGATING and sup.current_route is route
    assert sup.pose == sim.pose


def test_go_to_pose_is_a_single_free_waypoint(sup: Supervisor) -> None:
    target = Pose2D(3.0, 4.0, 1.0)
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(GoToPose(target))
    assert sim.tick()[-1] == RouteStarted((target,), (None,), None)
    sim.follow_route()
    assert sim.of(GoalReached) == [GoalReached(None, target)]
    assert sim.of(TaskFinished)[0].ok


def test_goal_already_reached_finishes_when_the_robot_says_so(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(0.1, 0.0, 0.0))
    sup.submit(GoHome())
    sup.submit(GoTo(1))
    events = sim.tick()  # the route is sent; the robot, already there, reports success
    kinds = [type(e) for e in events]
    assert kinds == [TaskStarted, QueueChanged, RouteStarted, GoalReached, TaskFinished]
    events = sim.tick()  # the next task starts at the next clock
    assert [type(e) for e in events] == [TaskStarted, QueueChanged, RouteStarted]


def test_poses_alone_never_finish_a_task_the_robot_judges(sup: Supervisor) -> None:
    """The supervisor has no goal logic: a pose on the goal is not an arrival."""
    goal = sup.topo.node(1).pose
    sup.submit(GoTo(1))
    sup.update(0.0, Pose2D(0.0, 0.0, 0.0))
    for k in range(5):
        assert sup.update(0.1 * (k + 1), goal) == []
    assert sup.state is SupervisorState.NAVIGATING and sup.route_index == 0
    assert sup.distance_to_next_goal == pytest.approx(0.0)


def test_robot_progress_is_mirrored_in_order_never_backwards(
    sup: Supervisor, topo: TopologicalMap
) -> None:
    sup.submit(GoTo(3))
    sup.update(0.0, Pose2D(0.0, 0.0, 0.0))  # route 1, 2, 3
    assert sup.robot_progress(2) == [IntermediateGoalReached(1, 0), IntermediateGoalReached(2, 1)]
    assert sup.route_index == 2
    assert sup.robot_progress(1) == [] and sup.route_index == 2  # a late, older report
    assert sup.robot_progress(99) == [] and sup.route_index == 2  # clipped to the final goal
    with pytest.raises(ValueError, match="integer >= 0"):
        sup.robot_progress(-1)
    assert [type(e) for e in sup.robot_route_succeeded(1.0)] == [GoalReached, TaskFinished]
    assert sup.robot_progress(0) == []  # no route being followed


def test_unreachable_goal_finishes_with_reason() -> None:
    nodes = [
        {"id": 0, "name": "A", "x": 0.0, "y": 0.0, "yaw": 0.0},
        {"id": 1, "name": "B", "x": 5.0, "y": 0.0, "yaw": 0.0},
    ]
    sup = Supervisor(TopologicalMap.from_dict({"nodes": nodes, "arcs": []}, source="t.yaml"))
    sup.submit(GoTo(1))
    events = sup.update(0.0, Pose2D(0.0, 0.0, 0.0))
    finished = events[-1]
    assert isinstance(finished, TaskFinished) and not finished.ok
    assert "no route from node 0 (A) to node 1 (B)" in finished.reason
    with pytest.raises(TaskRejectedError, match=r"no node of t\.yaml has 'tour: true'"):
        sup.submit(GuidedTour())


def test_config_and_planner_validation(topo: TopologicalMap) -> None:
    with pytest.raises(
        ValueError, match=r"request_timeout = 0\.0 s is outside the allowed range \(0, inf\) s"
    ):
        SupervisorConfig(request_timeout=0.0)
    with pytest.raises(
        ValueError, match=r"yaw_tolerance = 7\.0 rad is outside the allowed range \[0\.001, 3\.14"
    ):
        SupervisorConfig(yaw_tolerance=7.0)
    with pytest.raises(ValueError, match=r"goal_tolerance must be a number \[m\], got True"):
        SupervisorConfig(goal_tolerance=True)
    other = load_topological_map(FIXTURE)
    with pytest.raises(ValueError, match="different topological map"):
        Supervisor(topo, RoutePlanner(other))
    with pytest.raises(ValueError, match="finite time"):
        Supervisor(topo).update(math.nan, None)


def test_robot_reported_success_settles_arrival(sup: Supervisor, topo: TopologicalMap) -> None:
    """The robot's success settles the goal, the waypoints it did not report included."""
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(GoTo(3))
    sim.tick()
    assert sup.robot_route_succeeded(sim.now) == [
        IntermediateGoalReached(1, 0),
        IntermediateGoalReached(2, 1),
        GoalReached(3, topo.node(3).pose),
        TaskFinished(GoTo(3), True, "reached node 3 (Bar)"),
    ]
    assert sup.state is SupervisorState.IDLE
    assert sup.robot_route_succeeded(sim.now) == []  # nothing to settle any more


def test_robot_aborted_route_fails_the_task(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(0.0, 0.0, 0.0))
    sup.submit(GoTo(3))
    sup.submit(GoTo(1))
    sim.tick()
    events = sup.robot_route_aborted("blocked: no path")
    assert events == [TaskFinished(GoTo(3), False, "robot aborted the route: blocked: no path")]
    assert sup.current_task is None
    sim.tick()
    assert sup.current_task == GoTo(1)  # the queue goes on


def test_robot_success_at_a_tour_stop_pauses_the_tour(sup: Supervisor) -> None:
    sim = Sim(sup, Pose2D(3.0, 0.0, 0.0))  # 3 m from the first stop: still driving
    sup.submit(GuidedTour())
    sim.tick()
    assert sup.state is SupervisorState.NAVIGATING
    first = sup.tour_stops[0]
    events = sup.robot_route_succeeded(sim.now)
    assert [type(e) for e in events] == [TourStopReached]
    assert sup.state is SupervisorState.AT_TOUR_STOP and sup.visited_tour_stops == (first,)


def test_a_held_queue_starts_nothing_until_released() -> None:
    from pathlib import Path

    from interbot_core.supervisor import GoTo, Supervisor, SupervisorState
    from interbot_core.topological_map import load_topological_map

    topo = load_topological_map(
        Path(__file__).resolve().parents[2] / "maps" / "isr_floor0_topo.yaml"
    )
    sup = Supervisor(topo)
    sup.hold_queue()
    sup.submit(GoTo(5))
    sup.update(0.0, topo.nodes[0].pose)
    assert sup.current_task is None and sup.state is SupervisorState.QUEUE_HELD
    assert sup.hold_queue() == []  # idempotent
    sup.release_queue()
    sup.update(0.1, topo.nodes[0].pose)
    assert sup.current_task == GoTo(5)
