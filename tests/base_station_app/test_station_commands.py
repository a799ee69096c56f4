"""TaskCommands and RobotReports, the controller's parts for the operator's commands and for what
the robots say (issue 13 split): driven without Qt or zenoh, on fakes of the link."""

from __future__ import annotations

import threading
from typing import Any, cast

import pytest

from base_station_app.alerts import AlertList, AlertRules
from base_station_app.fleet import Fleet
from base_station_app.robot_mirror import RobotMirror
from base_station_app.robot_reports import RobotReports
from base_station_app.station_config import StationConfig
from base_station_app.supervisor_events import Notices, SupervisorEvents
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.task_commands import INITIAL_POSE_SETTLE_S, TaskCommands
from interbot_core import protocol as p
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import GoTo, SupervisorConfig
from interbot_core.topics import InitialPose, PoseMsg, Status, Topic
from interbot_core.topological_map import TopologicalMap
from interbot_link import RobotAppeared, RobotLeft, StateMessage


class FakeStationLink:
    """What `RobotReports` polls: queued events, no high-rate state; records state requests."""

    def __init__(self) -> None:
        self.events: list[object] = []
        self.asked: list[str] = []
        self.selected = "a"

    def poll_events(self) -> list[object]:
        events, self.events = self.events, []
        return events

    def poll_state(self) -> dict[Topic, object]:
        return {}

    def request_state(self, robot_id: str) -> None:
        self.asked.append(robot_id)


class FakeFleetLink:
    """`FleetLink` as the parts use it: the gates, sending (recorded), the watch's upkeep."""

    def __init__(self) -> None:
        self.link = FakeStationLink()
        self.watch = None
        self.estop_latched, self.robot_online = False, True
        self.sent: list[tuple[Topic, object]] = []
        self.synced = 0

    def send(self, topic: Topic, message: object) -> bool:
        self.sent.append((topic, message))
        return True

    def send_to(self, mirror: RobotMirror, topic: Topic, message: object) -> bool:
        return self.send(topic, message)

    def sync_watch(self) -> None:
        self.synced += 1


class Rig:
    def __init__(self, topo: TopologicalMap) -> None:
        planner = RoutePlanner(topo)
        self.fleet = Fleet(lambda r: RobotMirror(r, topo, planner, SupervisorConfig()))
        self.fleet.select("a")
        self.link, self.policy, self.alerts = FakeFleetLink(), TabletPolicy(), AlertList()
        self.tablet: list[object] = []
        self.logs: list[tuple[str, str]] = []
        self.changes: list[str] = []
        self.now = 10.0
        notices = Notices(
            lambda level, text: self.logs.append((level, text)),
            lambda: self.changes.append("tasks"),
            lambda paused: None,
            lambda event: None,
            lambda event: None,
            lambda msg: None,
        )
        clock = lambda: self.now  # noqa: E731
        link = cast(Any, self.link)
        names = {n.id: n.name for n in topo.nodes}
        ids = iter(range(1, 100))
        self.events = SupervisorEvents(
            self.fleet,
            link,
            self.tablet.append,
            self.policy,
            self.alerts,
            notices,
            StationConfig(),
            names,
            clock,
            lambda: next(ids),
        )
        self.stopped: list[str] = []
        self.commands = TaskCommands(
            self.fleet,
            self.events,
            link,
            self.policy,
            self.tablet.append,
            self.stopped.append,
            topo,
            notices,
            clock,
        )
        self.lock = threading.RLock()
        self.reports = RobotReports(
            self.fleet,
            link,
            self.events,
            AlertRules(self.alerts),
            self.lock,
            notices.log,
            lambda: self.changes.append("robots"),
            clock,
        )


@pytest.fixture
def rig(topo: TopologicalMap) -> Rig:
    return Rig(topo)


def test_a_task_the_map_rejects_is_told_only_to_the_tablet_that_asked(rig: Rig) -> None:
    assert not rig.commands.submit(GoTo(10_000))  # the operator's: logged, the tablet not told
    assert rig.tablet == [] and rig.logs[-1][0] == "error"
    assert not rig.commands.submit(GoTo(10_000), from_tablet=True)
    (report,) = rig.tablet
    assert isinstance(report, p.ErrorReport) and report.code == "task_rejected"
    assert rig.policy.tasks == []  # nothing adopted


def test_a_tablets_task_cancelled_by_the_operator_tells_the_tablet(
    rig: Rig, topo: TopologicalMap
) -> None:
    supervisor = rig.fleet.selected.supervisor
    for who, told in (("the operator", True), ("the tablet", False)):  # its own Stop: it knows
        rig.tablet.clear()
        assert rig.commands.submit(GoTo(3), from_tablet=True)
        rig.events.handle(supervisor.update(rig.now, topo.node(0, "start").pose))  # it starts
        assert supervisor.current_task == GoTo(3)
        assert rig.commands.cancel_task(who)
        assert supervisor.current_task is None
        assert (p.Cancel(f"cancelled by {who}") in rig.tablet) is told


def test_the_queue_resumes_only_once_the_stop_is_released(rig: Rig) -> None:
    rig.events.handle(rig.fleet.selected.supervisor.hold_queue())
    rig.link.estop_latched = True
    rig.commands.resume_queue()
    assert rig.fleet.selected.supervisor.held
    assert rig.logs[-1] == ("warning", "release the emergency stop before resuming the queue")
    rig.link.estop_latched = False
    rig.commands.resume_queue()
    assert not rig.fleet.selected.supervisor.held


def test_a_room_as_initial_pose_is_checked_by_the_robot_and_holds_back_stale_states(
    rig: Rig, topo: TopologicalMap
) -> None:
    rig.commands.set_initial_pose_room(3)
    ((topic, msg),) = rig.link.sent
    node = topo.node(3, "room").pose
    assert topic is Topic.INITIAL_POSE and isinstance(msg, InitialPose)
    assert (msg.x, msg.y, msg.verify) == (node.x, node.y, True)
    assert rig.fleet.selected.pose_settling_until == rig.now + INITIAL_POSE_SETTLE_S


def test_a_robot_that_appears_is_asked_its_state_and_one_that_leaves_raises_an_alert(
    rig: Rig,
) -> None:
    rig.link.link.events = [RobotAppeared("b")]
    rig.reports.poll(display=False)
    b = rig.fleet.mirrors["b"]
    assert b.online and rig.link.link.asked == ["b"] and rig.link.synced == 1
    assert rig.changes == ["robots"] and not rig.alerts.unacknowledged
    rig.link.link.events = [RobotLeft("b")]
    rig.reports.poll(display=False)
    assert not b.online and rig.changes == ["robots", "robots"]
    assert [a.robot for a in rig.alerts.unacknowledged] == ["b"]


def test_a_robots_messages_go_into_its_own_mirror_and_strangers_are_ignored(rig: Rig) -> None:
    rig.link.link.events = [
        RobotAppeared("b"),
        StateMessage("b", Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="ok")),
        StateMessage("b", Topic.STATUS, Status("warning", "bumper pressed")),
        StateMessage("zz", Topic.POSE, PoseMsg(5.0, 5.0, 0.0, state="ok")),  # never announced
    ]
    rig.reports.poll(display=False)
    pose = rig.fleet.mirrors["b"].state.pose
    assert pose is not None and (pose.x, pose.y) == (1.0, 2.0)
    assert "zz" not in rig.fleet.mirrors
    assert any("bumper pressed" in text and "b" in text for _, text in rig.logs)
