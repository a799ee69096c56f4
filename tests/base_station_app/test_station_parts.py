"""The station controller's Qt-free parts (issue 13 split, issue 14 fleet): no Qt, no zenoh."""

from __future__ import annotations

import pytest

from base_station_app.fleet import Ask, Fleet, Select, Waiting
from base_station_app.robot_mirror import Health, RobotMirror
from base_station_app.tablet_feed import TabletFeed
from base_station_app.tablet_policy import TabletPolicy, with_kind
from base_station_app.teleop import Direction
from base_station_app.teleop_arbiter import Forward, Refuse, TeleopArbiter
from interbot_core import protocol as p
from interbot_core.geometry import Pose2D
from interbot_core.route_mirror import RouteLost
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import GoTo, RouteStarted, SupervisorConfig
from interbot_core.topics import MuxMsg, PoseMsg, RouteProgress, Topic
from interbot_core.topological_map import TopologicalMap


@pytest.fixture
def fleet(topo: TopologicalMap) -> Fleet:
    planner = RoutePlanner(topo)
    return Fleet(lambda r: RobotMirror(r, topo, planner, SupervisorConfig()), grace_s=0.5)


def online(fleet: Fleet, *robots: str) -> None:
    for r in robots:
        fleet.mirror(r).online = True


def test_one_robot_is_selected_after_the_grace_several_are_asked_for_once(fleet: Fleet) -> None:
    assert fleet.choose(5.0) is None  # no robot yet: the grace has not begun
    online(fleet, "b")
    assert fleet.choose(10.0) is None  # discovery still running
    online(fleet, "a")
    assert fleet.choose(10.4) is None
    assert fleet.choose(10.6) == Ask(("a", "b"))  # never "the first seen"
    assert fleet.choose(10.7) is None  # asked once for this set
    online(fleet, "c")
    assert fleet.choose(10.8) == Ask(("a", "b", "c"))  # a new robot: ask again

    single = Fleet(fleet._make, grace_s=0.5)
    online(single, "only")
    single.choose(0.0)
    assert single.choose(0.6) == Select("only")


def test_a_preferred_robot_is_waited_for_and_nothing_else_chosen(fleet: Fleet) -> None:
    fleet.preferred = "c"
    online(fleet, "a", "b")
    assert fleet.choose(0.0) is None
    assert fleet.choose(99.0) == Waiting("c", ("a", "b"))  # said, neither asked nor picked
    assert fleet.choose(99.05) is None  # once
    online(fleet, "c")
    assert fleet.choose(99.1) == Select("c")
    fleet.select("c")
    assert fleet.choose(99.2) is None  # chosen: nothing more to decide


def test_each_robot_has_its_own_queue_and_the_first_adopts_earlier_orders(fleet: Fleet) -> None:
    fleet.selected.supervisor.submit(GoTo(3))  # before any robot: the placeholder takes it
    fleet.selected.supervisor.submit(GoTo(4))
    _, a = fleet.select("a")
    assert a.supervisor.current_task == GoTo(3) or GoTo(3) in a.supervisor.queue
    _, b = fleet.select("b")
    assert b.supervisor is not a.supervisor
    assert b.supervisor.queue == () and b.supervisor.current_task is None
    b.supervisor.submit(GoTo(5))
    assert GoTo(5) not in a.supervisor.queue
    assert [m.robot_id for m in fleet.all()] == ["a", "b"]


def test_health_names_the_state_colour(topo: TopologicalMap) -> None:
    m = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    assert m.health is Health.OFFLINE
    m.online = True
    assert m.health is Health.LOST  # no pose yet
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="ok"))
    assert m.health is Health.OK
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="degraded"))
    assert m.health is Health.DEGRADED
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="searching"))
    assert m.health is Health.LOST
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="turning"))
    assert m.health is Health.LOST
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="searching"))
    m.state.apply(Topic.MUX, MuxMsg(None, active_locks=("Emergency Stop",)))
    assert m.health is Health.STOPPED
    m.online = False
    assert m.health is Health.OFFLINE
    view = m.view(False, {})
    assert view.pose is not None and view.pose.x == 1.0 and view.health is Health.OFFLINE


def test_arbiter_forwards_fresh_tablet_commands_once_and_zeroes_once() -> None:
    arb = TeleopArbiter(0.5, 0.5, 1.0)
    verdict = arb.on_tablet_speed(p.Speed(0.2, 0.1, seq=1, t=0.0), 10.0, stopped=False)
    assert isinstance(verdict, Forward) and verdict.twist.stamp == 10.0
    assert arb.on_tablet_speed(p.Speed(0.2, 0.1, seq=1, t=0.0), 10.1, stopped=False) is None
    assert arb.stop_tablet() is True  # one explicit zero
    assert arb.stop_tablet() is False  # and only one
    assert arb.on_tablet_speed(p.Speed(0.2, 0.1, seq=2), 10.2, stopped=True) == Refuse(
        "emergency stop engaged: speed ignored"
    )
    assert arb.on_tablet_speed(p.Speed(0.2, 0.1, seq=3), 10.3, stopped=True) is None  # told


def test_arbiter_tells_a_refusal_once_per_stream_and_reason() -> None:
    arb = TeleopArbiter(0.5, 0.5, 1.0)
    assert arb.tell("the operator does not allow teleop from the tablet")
    assert not arb.tell("the operator does not allow teleop from the tablet")  # same stream
    assert arb.tell("the robot is offline: teleop cannot work")  # a new reason is told
    assert isinstance(arb.on_tablet_speed(p.Speed(0.1, 0.0, seq=1), 1.0, False), Forward)
    assert arb.tell("the robot is offline: teleop cannot work")  # driving resumed in between
    arb.tablet_connected()
    assert arb.tell("the robot is offline: teleop cannot work")  # a new connection


def test_arbiter_keys_send_while_held_and_one_zero_on_release() -> None:
    arb = TeleopArbiter(0.5, 0.4, 1.0)
    arb.keys.press(Direction.FORWARD)
    assert arb.keys_changed(stopped=False) == (0.4, 0.0)
    assert arb.keys_command(stopped=True) is None  # nothing during a stop
    arb.keys.release(Direction.FORWARD)
    assert arb.keys_changed(stopped=False) == (0.0, 0.0)
    assert arb.keys_changed(stopped=False) is None


def test_tablet_policy_refuses_with_the_reason_and_owns_by_identity() -> None:
    policy = TabletPolicy()
    assert policy.refusal("goals", robot_online=True, estop_latched=False) is None
    assert "offline" in str(policy.refusal("goals", robot_online=False, estop_latched=False))
    assert "emergency stop" in str(policy.refusal("teleop", True, True))
    policy.permissions = with_kind(policy.permissions, "tours", False)
    assert "does not allow tours" in str(policy.refusal("tours", True, False))
    assert policy.refusal(None, False, True) is None  # stop, pause, help: always
    mine, equal = GoTo(3), GoTo(3)
    policy.adopt(mine)
    assert policy.owns(mine) and not policy.owns(equal)  # the object, not its value
    policy.forget(mine)
    assert not policy.owns(mine)


def test_a_route_is_sent_once_mirrored_and_its_end_said_once(topo: TopologicalMap) -> None:
    m = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    started = RouteStarted((Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, 0.0, 0.0)), (None, 4), 4)
    msg = m.new_route(7, started, approach_tolerance=1.0, goal_tolerance=0.2, yaw_tolerance=0.3)
    assert m.route is msg and msg.node_ids == ()  # a pose goal: no node list
    m.route_sent(False)
    assert [lost.route_id for lost in m.due_losses(0.0)] == [7]  # nobody received it
    assert m.due_losses(0.0) == []  # said once
    assert m.lose_route(RouteLost(7, "gone")) and m.route is None
    msg = m.new_route(8, started, approach_tolerance=1.0, goal_tolerance=0.2, yaw_tolerance=0.3)
    m.route_sent(True)
    assert m.route_mirror.route_id == 8
    m.state.apply(Topic.ROUTE_PROGRESS, RouteProgress(8, 1, False, "active"))
    progress = m.route_progress()
    assert progress is not None and not m.verdict(progress) and m.route_index == 1
    m.state.apply(Topic.ROUTE_PROGRESS, RouteProgress(8, 1, True, "succeeded"))
    progress = m.route_progress()
    assert progress is not None and m.verdict(progress)
    assert not m.verdict(progress)  # once per route
    m.state.apply(Topic.ROUTE_PROGRESS, RouteProgress(9, 0, False, "active"))
    assert m.route_progress() is None  # another route's report is not ours
    assert not m.lose_route(RouteLost(99, "another route"))
    assert m.drop_route() == 8 and m.route is None


def test_tablet_feed_says_changes_only_and_nothing_stale_while_offline(
    topo: TopologicalMap,
) -> None:
    from interbot_core import protocol as p

    m = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    feed = TabletFeed()
    status = p.StatusInfo("idle", "robot offline")
    assert feed.messages(m, 0.0, False, status) == [status]
    assert feed.messages(m, 0.1, False, status) == []  # said once
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.5, state="ok"))
    ready = p.StatusInfo("idle", "idle")
    first = feed.messages(m, 0.2, True, ready)
    assert p.Localisation("ok") in first and p.Pose(1.0, 2.0, 0.5) in first and ready in first
    again = feed.messages(m, 0.3, True, ready)
    assert again == [p.Pose(1.0, 2.0, 0.5)]  # the pose every clock, the rest on change
    m.state.apply(Topic.POSE, PoseMsg(1.0, 2.0, 0.5, state="lost"))
    m.pose_settling_until = 1.0  # an initial pose was just sent: "lost" is stale
    assert p.Localisation("lost") not in feed.messages(m, 0.4, True, ready)
    assert p.Localisation("lost") in feed.messages(m, 1.1, True, ready)


def test_a_start_up_search_reaches_the_tablet_as_such_with_no_pose_drawn(
    topo: TopologicalMap,
) -> None:
    """Issue 16: switched on with its pose unset, the robot searches (and turns, when it has a
    task) before it has any pose: the tablet hears "turning", not "unset" (no "Help me!"
    banner), and the station draws no robot at the message's meaningless (0, 0)."""
    from interbot_core import protocol as p

    m = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    m.online = True
    feed = TabletFeed()
    ready = p.StatusInfo("idle", "idle")
    m.state.apply(Topic.POSE, PoseMsg(0.0, 0.0, 0.0, state="turning", confidence=0.0))
    out = feed.messages(m, 0.0, True, ready)
    assert p.Localisation("turning") in out
    assert not any(isinstance(msg, (p.InitialPose, p.Pose)) for msg in out)
    assert m.view(True, {}).pose is None and m.health is Health.LOST
    m.state.apply(Topic.POSE, PoseMsg(0.0, 0.0, 0.0, state="unset", confidence=0.0))
    assert p.InitialPose(False) in feed.messages(m, 0.1, True, ready)  # search gave up


def test_a_robots_messages_land_in_its_mirror_which_says_what_to_act_on(
    topo: TopologicalMap,
) -> None:
    from interbot_core.supervisor import GoalReached, RequestShown, TaskFinished, TaskStarted
    from interbot_core.topics import Status

    m = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    m.new_route(8, RouteStarted((Pose2D(0.0, 0.0, 0.0),), (4,), 4), approach_tolerance=1.0,
                goal_tolerance=0.2, yaw_tolerance=0.3)  # fmt: skip
    m.route_sent(True)
    m.route_mirror.reconnected(0.0)  # asked the robot: its next report is checked
    assert m.on_message(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="ok")) == (None, [])
    assert m.state.pose is not None and m.state.pose.x == 1.0
    lost, _ = m.on_message(Topic.ROUTE_PROGRESS, RouteProgress(0, 0, False, "idle"))
    assert lost is not None and lost.route_id == 8  # the robot restarted: our route is gone
    assert m.on_message(Topic.STATUS, Status("info", "")) == (None, [])  # nothing to log
    _, lines = m.on_message(Topic.STATUS, Status("warning", "blocked by a door"))
    assert [line.text for line in lines] == ["blocked by a door"]
    m.on_event(GoalReached(4, Pose2D(0.0, 0.0, 0.0)))
    assert m.goal_reached
    m.on_event(TaskStarted(GoTo(5)))
    assert not m.goal_reached
    m.shown_request = (1, RequestShown("coffee", 3, 4, 10.0))
    m.on_event(TaskFinished(GoTo(5), True, "done"))
    assert m.shown_request is None


def test_alert_rules_take_any_message_by_its_kind() -> None:
    from base_station_app.alerts import AlertList, AlertRules
    from interbot_core.topics import Battery, Status

    alerts = AlertList()
    rules = AlertRules(alerts)
    rules.on_message("r", PoseMsg(0.0, 0.0, 0.0, state="ok"), 0.0)
    rules.on_message("r", PoseMsg(0.0, 0.0, 0.0, state="lost"), 1.0)
    rules.on_message("r", Status("error", "collision: bumper"), 2.0)
    rules.on_message("r", Battery(23.0, soc=0.05), 3.0)
    rules.on_message("r", MuxMsg(None), 4.0)  # no rule for it: ignored
    assert [a.kind for a in alerts.alerts] == ["lost", "collision", "battery"]


def test_standing_notices_are_logged_once_whether_the_station_heard_them_or_joined_later(
    topo: TopologicalMap,
) -> None:
    """A standing notice (the wall model the localiser learnt) is a status line and an entry of
    the robot's notices: a station that heard the line logs it once; one that joined later
    logs it from the snapshot's notices; a snapshot read again logs nothing new."""
    from interbot_core.topics import StandingNotices, Status

    learnt = Status("info", "walls learnt at cell centres", stamp=12.0)
    later = Status("info", "odometry scale learnt", stamp=30.0)
    live = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    assert live.on_message(Topic.STATUS, learnt)[1] == [learnt]
    assert live.on_message(Topic.NOTICES, StandingNotices((learnt,)))[1] == []
    assert live.on_message(Topic.NOTICES, StandingNotices((learnt, later)))[1] == [later]
    assert live.on_message(Topic.STATUS, later)[1] == []  # its line came after its notice

    late = RobotMirror("r", topo, RoutePlanner(topo), SupervisorConfig())
    snapshot = StandingNotices((learnt, later))
    assert late.on_message(Topic.NOTICES, snapshot)[1] == [learnt, later]
    assert late.on_message(Topic.STATUS, later)[1] == []  # the snapshot's newest status line
    assert late.on_message(Topic.NOTICES, snapshot)[1] == []  # asked again (a reconnect)
