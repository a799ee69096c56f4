"""SupervisorEvents: what every robot's supervisor events become (issue 13 split; no Qt, no zenoh)."""

from __future__ import annotations

from typing import Any, cast

import pytest

from base_station_app.alerts import AlertList
from base_station_app.fleet import Fleet
from base_station_app.robot_mirror import RobotMirror
from base_station_app.station_config import StationConfig
from base_station_app.supervisor_events import Notices, SupervisorEvents
from base_station_app.tablet_policy import TabletPolicy
from interbot_core import protocol as p
from interbot_core.route_mirror import RouteLost
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import GoTo, RequestShown, SupervisorConfig, TourStopReached
from interbot_core.topics import MuxMsg, PoseMsg, RouteMsg, RouteProgress, Topic
from interbot_core.topological_map import TopologicalMap


class FakeFleetLink:
    """Records what is sent to which robot; ``heard`` says whether a robot received it."""

    def __init__(self) -> None:
        self.sent: list[tuple[str | None, Topic, object]] = []
        self.heard = True
        self.estop_latched = False  # the operator's stop (FleetLink's)

    def send_to(self, mirror: RobotMirror, topic: Topic, message: object) -> bool:
        self.sent.append((mirror.robot_id, topic, message))
        return self.heard


class Rig:
    def __init__(self, topo: TopologicalMap) -> None:
        planner = RoutePlanner(topo)
        self.topo = topo
        self.fleet = Fleet(lambda r: RobotMirror(r, topo, planner, SupervisorConfig()))
        self.link, self.alerts, self.policy = FakeFleetLink(), AlertList(), TabletPolicy()
        self.tablet: list[object] = []
        self.said: list[tuple[str, object]] = []  # (notice, argument)
        self.logs: list[tuple[str, str]] = []
        self.ids = iter(range(42, 100))
        notices = Notices(
            lambda level, text: self.logs.append((level, text)),
            lambda: self.said.append(("tasks", None)),
            lambda paused: self.said.append(("paused", paused)),
            lambda event: self.said.append(("tour_stop", event)),
            lambda event: self.said.append(("request", event)),
            lambda msg: self.said.append(("route", msg)),
        )
        self.events = SupervisorEvents(
            self.fleet,
            cast(Any, self.link),
            self.tablet.append,
            self.policy,
            self.alerts,
            notices,
            StationConfig(goal_tolerance=0.3),
            {n.id: n.name for n in topo.nodes},
            lambda: 10.0,
            lambda: next(self.ids),
        )
        self.fleet.select("a")
        self.a, self.b = self.fleet.mirror("a"), self.fleet.mirror("b")

    def start(self, mirror: RobotMirror, node: int = 3) -> RouteMsg:
        """Give ``mirror``'s supervisor a task and a pose: it plans and starts a route."""
        self.events.handle(mirror.supervisor.submit(GoTo(node)), mirror)
        self.events.handle(mirror.supervisor.update(1.0, self.topo.node(0, "start").pose), mirror)
        assert mirror.route is not None
        return mirror.route


@pytest.fixture
def rig(topo: TopologicalMap) -> Rig:
    return Rig(topo)


def test_a_route_is_sent_once_to_the_robot_that_planned_it_with_a_fresh_id(rig: Rig) -> None:
    route = rig.start(rig.b)
    routes = [(r, m) for r, t, m in rig.link.sent if t is Topic.ROUTE]
    assert routes == [("b", route)]  # to b only, although a is the selected robot
    assert route.route_id == 42 and route.goal_tolerance == 0.3 and route.node_ids[-1] == 3
    assert ("route", route) in rig.said and ("tasks", None) in rig.said
    assert (
        "info",
        f"[b] route 42: nodes {list(route.node_ids)}",
    ) in rig.logs  # named: not selected
    assert rig.a.route is None and rig.tablet == []


def test_a_route_nobody_received_ends_its_task_at_the_next_clock(rig: Rig) -> None:
    rig.link.heard = False
    rig.start(rig.a)
    (lost,) = rig.a.due_losses(11.0)
    rig.events.route_lost(lost, rig.a)
    assert rig.a.supervisor.current_task is None and rig.a.route is None
    assert ("error", "no robot received route 42") in rig.logs


def test_the_robots_abort_settles_the_task_once(rig: Rig) -> None:
    route = rig.start(rig.a)
    rig.a.state.progress = RouteProgress(route.route_id, 1, False, "aborted", "blocked")
    rig.events.robot_progress(rig.a)
    rig.events.robot_progress(rig.a)  # the same report again: nothing more
    assert rig.a.supervisor.current_task is None
    assert [t for t in rig.logs if "gave up" in t[1]] == [
        ("error", "robot gave up route 42: blocked")
    ]
    # A report on a route that is not ours changes nothing.
    rig.start(rig.a, node=4)
    rig.a.state.progress = RouteProgress(7, 0, False, "aborted", "other")
    rig.events.robot_progress(rig.a)
    assert rig.a.supervisor.current_task == GoTo(4)


def test_a_lost_route_that_is_not_ours_ends_nothing(rig: Rig) -> None:
    rig.start(rig.a)
    rig.events.route_lost(RouteLost(7, "robot restarted"), rig.a)
    assert rig.a.supervisor.current_task == GoTo(3)


def test_a_tour_stop_pauses_its_robot_and_only_the_selected_one_tells_the_tablet(
    rig: Rig,
) -> None:
    stop = TourStopReached(5, "info", "Auditorium", (5,), None)
    rig.events.handle([stop], rig.a)
    assert rig.tablet == [p.GoalStatus(5, True, True)]
    assert ("tour_stop", stop) in rig.said and rig.alerts.unacknowledged == []
    assert ("a", Topic.PAUSE_NAV) in [(r, t) for r, t, _ in rig.link.sent]  # waits at the stop
    rig.events.handle([stop], rig.b)
    assert rig.tablet == [p.GoalStatus(5, True, True)]  # b is not the tablet's robot
    (alert,) = rig.alerts.unacknowledged
    assert alert.kind == "waiting" and alert.robot == "b" and "Auditorium" in alert.text


def test_requests_are_numbered_and_another_robots_raises_an_alert(rig: Rig) -> None:
    shown = RequestShown("coffee", 5, 2, deadline=60.0)
    rig.events.handle([shown], rig.a)
    rig.events.handle([shown], rig.b)
    assert rig.a.shown_request == (1, shown) and rig.b.shown_request == (2, shown)
    assert rig.tablet == [p.ShowRequest(1, "coffee", 5, 2)]
    assert [a.robot for a in rig.alerts.unacknowledged] == ["b"]


def _pose(state: str, known: bool = True) -> PoseMsg:
    """The robot's pose message: with the pose it had, or a start-up search's (no pose)."""
    if known:
        return PoseMsg(19.0, 0.5, 0.0, 5.0, state, 0.3, (0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01))
    return PoseMsg(0.0, 0.0, 0.0, 5.0, state, 0.0)


def test_a_robot_that_lost_its_pose_is_sent_its_next_leg_as_the_goal_alone(rig: Rig) -> None:
    """Issue 16: the clock's pose section gives the supervisor the robot's condition; a robot
    searching with the pose it had gets the due leg once, as its goal node's pose."""
    a = rig.a
    a.online = True
    a.state.apply(Topic.POSE, _pose("ok"))
    rig.events.update_poses(1.0)  # the station saw a pose
    a.state.apply(Topic.POSE, _pose("searching"))
    rig.events.handle(a.supervisor.submit(GoTo(3)), a)
    rig.events.update_poses(2.0)
    routes = [m for r, t, m in rig.link.sent if t is Topic.ROUTE]
    goal = rig.topo.node(3).pose
    assert [(r.waypoints, r.node_ids) for r in routes] == [(((goal.x, goal.y, goal.yaw),), (3,))]
    assert a.status_text(estop_latched=False) == "waiting for pose"
    assert rig.logs[-1] == (
        "info",
        "route 42: nodes [3] (the goal alone: the robot plans to it from the position it finds)",
    )
    a.state.apply(Topic.POSE, _pose("ok"))  # found: it plans; nothing is re-sent
    rig.events.update_poses(3.0)
    assert len([t for _, t, _ in rig.link.sent if t is Topic.ROUTE]) == 1


@pytest.mark.parametrize(
    ("online", "pose", "latched", "mux_locks", "expected"),
    [
        (True, _pose("searching"), False, (), (True, False, True)),
        (True, _pose("turning"), False, (), (True, False, True)),
        (True, _pose("lost"), False, (), (True, False, True)),
        (True, _pose("searching", known=False), False, (), (True, False, False)),  # start-up
        (True, _pose("unset", known=False), False, (), (True, False, False)),
        (True, _pose("ok"), False, (), (True, False, False)),
        (True, None, False, (), (True, False, False)),
        (False, _pose("searching"), False, (), (False, False, True)),
        (True, _pose("searching"), True, (), (True, True, True)),  # the operator's stop
        (True, _pose("searching"), False, ("Emergency Stop",), (True, True, True)),  # robot's
    ],
)
def test_the_robots_condition_comes_from_what_it_reports(
    rig: Rig,
    online: bool,
    pose: PoseMsg | None,
    latched: bool,
    mux_locks: tuple[str, ...],
    expected: tuple[bool, bool, bool],
) -> None:
    a = rig.a
    a.online = online
    if pose is not None:
        a.state.apply(Topic.POSE, pose)
    a.state.apply(Topic.MUX, MuxMsg(None, active_locks=mux_locks))
    rig.link.estop_latched = latched
    c = rig.events.condition(a)
    assert (c.connected, c.stopped, c.finding) == expected
