"""FleetLink: sending to the fleet and the must-arrive state (no Qt, no zenoh: fake link/watch)."""

from __future__ import annotations

from typing import Any, cast

import pytest

from base_station_app.fleet import Fleet
from base_station_app.fleet_link import STOP_REASSERT_S, FleetLink
from base_station_app.robot_mirror import RobotMirror
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import SupervisorConfig
from interbot_core.topics import AssistMsg, ConfigMsg, Lock, MuxMsg, StopRelease, Topic
from interbot_core.topological_map import TopologicalMap
from interbot_link import LinkError


class FakeLink:
    """The selected robot's link: records what was sent; ``heard`` says whether it matched."""

    def __init__(self) -> None:
        self.selected: str | None = None
        self.sent: list[tuple[Topic, object]] = []
        self.heard = True
        self.fail = False
        self.closed = False

    def send(self, topic: Topic, message: object) -> bool:
        if self.fail:
            raise LinkError("session closed")
        self.sent.append((topic, message))
        return self.heard

    def close(self) -> None:
        self.closed = True


class FakeWatch:
    def __init__(self) -> None:
        self.watched: set[str] = set()
        self.sent: list[tuple[str, Topic, object]] = []
        self.fail = False

    def set_watched(self, robots: set[str]) -> None:
        self.watched = set(robots)

    def send(self, robot_id: str, topic: Topic, message: object) -> bool:
        if self.fail:
            raise LinkError("publisher gone")
        self.sent.append((robot_id, topic, message))
        return True

    def close(self) -> None:
        pass


class Rig:
    def __init__(self, topo: TopologicalMap) -> None:
        planner = RoutePlanner(topo)
        self.fleet = Fleet(lambda r: RobotMirror(r, topo, planner, SupervisorConfig()))
        self.link, self.watch = FakeLink(), FakeWatch()
        self.logs: list[tuple[str, str]] = []
        self.now = 10.0
        self.out = FleetLink(
            cast(Any, self.link),
            cast(Any, self.watch),
            self.fleet,
            lambda: self.now,
            lambda level, text: self.logs.append((level, text)),
            ConfigMsg({"max_linear_speed": 0.5}),
        )

    def select(self, robot_id: str) -> RobotMirror:
        _, new = self.fleet.select(robot_id)
        self.link.selected = robot_id
        self.out.sync_watch()
        return new


@pytest.fixture
def rig(topo: TopologicalMap) -> Rig:
    return Rig(topo)


def topics(sent: list[tuple[Topic, object]]) -> list[Topic]:
    return [topic for topic, _ in sent]


def test_the_selected_robot_is_sent_to_through_the_link_others_through_the_watch(rig: Rig) -> None:
    other = rig.fleet.mirror("b")
    assert not rig.out.send(Topic.STOP, Lock(True))  # no robot selected: nobody heard it
    a = rig.select("a")
    assert rig.watch.watched == {"b"}  # every robot seen but the selected one
    assert rig.out.send_to(a, Topic.STOP, Lock(True))
    assert rig.out.send_to(other, Topic.STOP, Lock(True))
    assert rig.link.sent == [(Topic.STOP, Lock(True))]
    assert rig.watch.sent == [("b", Topic.STOP, Lock(True))]
    assert not rig.out.send_to(rig.fleet.mirror("c"), Topic.STOP, Lock(True))  # not watched yet


def test_a_send_error_is_logged_naming_the_robot_and_counts_as_not_received(rig: Rig) -> None:
    rig.select("a")
    other = rig.fleet.mirror("b")
    rig.out.sync_watch()
    rig.link.fail = rig.watch.fail = True
    assert not rig.out.send(Topic.ROUTE_CANCEL, object())
    assert not rig.out.send_to(other, Topic.PAUSE_NAV, Lock(True))
    assert rig.logs == [
        ("error", "cannot send route_cancel: session closed"),
        ("error", "[b] cannot send pause_nav: publisher gone"),
    ]


def test_after_close_nothing_is_sent(rig: Rig) -> None:
    a = rig.select("a")
    rig.out.close()
    assert rig.link.closed
    assert not rig.out.send_to(a, Topic.STOP, Lock(True))
    assert rig.link.sent == []


def test_must_arrive_state_stays_pending_until_a_robot_heard_it(rig: Rig) -> None:
    a = rig.select("a")
    a.commanded = True
    rig.link.heard = False  # linked, but no subscriber matched yet
    rig.out.resend_pending(a)
    assert (a.stop_assert_pending, a.config_pending, a.assist_pending) == (True, True, True)
    rig.link.heard = True
    rig.link.sent.clear()
    rig.out.resend_pending(a)
    assert (a.stop_assert_pending, a.config_pending, a.assist_pending) == (False, False, False)
    assert rig.link.sent == [
        (Topic.STOP, Lock(False, stamp=10.0)),  # released: the start latch of a commanded robot
        (Topic.STOP_RELEASE, StopRelease("base station (on connection)", stamp=10.0)),
        (Topic.CONFIG, ConfigMsg({"max_linear_speed": 0.5})),
        (Topic.TELEOP_ASSIST, AssistMsg("station_vel", False, stamp=10.0)),
    ]
    rig.link.sent.clear()
    rig.out.resend_pending(a)
    assert rig.link.sent == []  # heard: nothing re-sent

    rig.out.set_config(ConfigMsg({"max_linear_speed": 0.3}))
    rig.out.set_assist(True)
    assert rig.link.sent == [
        (Topic.CONFIG, ConfigMsg({"max_linear_speed": 0.3})),
        (Topic.TELEOP_ASSIST, AssistMsg("station_vel", True, stamp=10.0)),
    ]


def test_the_stop_goes_to_every_robot_the_release_only_to_commanded_ones(rig: Rig) -> None:
    a = rig.select("a")  # commanded (selected) from this station
    seen = rig.fleet.mirror("b")  # merely seen: watched
    rig.out.sync_watch()
    rig.out.estop_latched = True
    for mirror in (a, seen):
        rig.out.assert_stop_intent(mirror)
    assert rig.link.sent == [(Topic.STOP, Lock(True, stamp=10.0))]
    assert rig.watch.sent == [("b", Topic.STOP, Lock(True, stamp=10.0))]

    rig.out.estop_latched = False
    rig.link.sent.clear()
    rig.watch.sent.clear()
    for mirror in (a, seen):
        rig.out.assert_stop_intent(mirror)
    assert topics(rig.link.sent) == [Topic.STOP, Topic.STOP_RELEASE]
    assert rig.watch.sent == []  # its start latch stays until the operator selects it
    assert not seen.stop_assert_pending  # nothing left to send it


def test_a_robot_reporting_no_stop_is_told_again_at_most_every_half_second(rig: Rig) -> None:
    a = rig.select("a")
    rig.out.estop_latched = True
    rig.out.assert_stop_intent(a)
    a.state.apply(Topic.MUX, MuxMsg(None, "idle"))  # the robot: no stop
    assert a.state.estop_engaged is False
    rig.link.sent.clear()
    rig.now += STOP_REASSERT_S / 2
    rig.out.check_stop(rig.now, a)
    assert rig.link.sent == []  # too soon after the last
    rig.now += STOP_REASSERT_S / 2
    rig.out.check_stop(rig.now, a)
    assert rig.link.sent == [(Topic.STOP, Lock(True, stamp=rig.now))]
    assert rig.logs == [("warning", "the robot reports no emergency stop: sending it again")]

    rig.out.estop_latched = False
    rig.link.sent.clear()
    rig.now += 1.0
    rig.out.check_stop(rig.now, a)
    assert rig.link.sent == []  # released: nothing to re-assert
