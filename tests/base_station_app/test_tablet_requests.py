"""TabletRequests: what the tablet's requests become on the station (issue 13 split; no Qt)."""

from __future__ import annotations

import pytest

from base_station_app.alerts import AlertList, AlertRules
from base_station_app.fleet import Fleet
from base_station_app.robot_mirror import RobotMirror
from base_station_app.tablet_policy import TabletPolicy, with_kind
from base_station_app.tablet_requests import TabletRequests
from interbot_core import protocol as p
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import GoTo, GuidedTour, RequestShown, SupervisorConfig, Task
from interbot_core.topological_map import TopologicalMap


class FakeStation:
    """The station's commands: records each call; a submitted task really is queued."""

    def __init__(self, fleet: Fleet, policy: TabletPolicy) -> None:
        self.fleet, self.policy = fleet, policy
        self.robot_online, self.estop_latched = True, False
        self.calls: list[tuple[object, ...]] = []
        self.logs: list[tuple[str, str]] = []

    def submit(self, task: Task, *, from_tablet: bool = False) -> bool:
        self.calls.append(("submit", task, from_tablet))
        self.fleet.selected.supervisor.submit(task)
        if from_tablet:
            self.policy.adopt(task)
        return True

    def cancel_task(self, who: str = "the operator") -> bool:
        self.calls.append(("cancel_task", who))
        return True

    def pause(self) -> None:
        self.calls.append(("pause",))

    def resume(self) -> None:
        self.calls.append(("resume",))

    def tour_resume(self) -> bool:
        self.calls.append(("tour_resume",))
        return True

    def tour_end(self) -> bool:
        self.calls.append(("tour_end",))
        return True

    def answer_request(self, accepted: bool) -> bool:
        self.calls.append(("answer_request", accepted))
        return True

    def set_initial_pose_room(self, node_id: int) -> None:
        self.calls.append(("initial_pose_room", node_id))

    def stop_motion(self, who: str) -> None:
        self.calls.append(("stop_motion", who))

    def stop_tablet_speed(self, why: str) -> None:
        self.calls.append(("stop_tablet_speed", why))

    def log(self, level: str, text: str) -> None:
        self.logs.append((level, text))


class Rig:
    def __init__(self, topo: TopologicalMap) -> None:
        planner = RoutePlanner(topo)
        self.fleet = Fleet(lambda r: RobotMirror(r, topo, planner, SupervisorConfig()))
        self.fleet.select("a")
        self.policy, self.alerts = TabletPolicy(), AlertList()
        self.station = FakeStation(self.fleet, self.policy)
        self.tablet: list[object] = []
        names = {n.id: n.name for n in topo.nodes}
        self.requests = TabletRequests(
            self.policy,
            self.fleet,
            self.station,
            self.tablet.append,
            AlertRules(self.alerts),
            names,
            lambda: 5.0,
        )

    def errors(self) -> list[str]:
        return [m.code for m in self.tablet if isinstance(m, p.ErrorReport)]


@pytest.fixture
def rig(topo: TopologicalMap) -> Rig:
    return Rig(topo)


def test_a_refused_request_is_told_with_its_reason_and_raises_an_alert(rig: Rig) -> None:
    rig.policy.permissions = with_kind(rig.policy.permissions, "goals", False)
    rig.requests.on_message(p.Goal(3))
    rig.station.estop_latched = True
    rig.requests.on_message(p.Tour(True))
    assert rig.station.calls == []  # nothing acted on
    assert [m.message for m in rig.tablet if isinstance(m, p.ErrorReport)] == [
        "the operator does not allow goals from the tablet",
        "emergency stop engaged: tours ignored",
    ]
    assert len(rig.alerts.unacknowledged) >= 1
    rig.station.estop_latched, rig.station.robot_online = False, False
    rig.requests.on_message(p.Malfunction("other", "smoke"))  # always heard, even offline
    assert ("error", "tablet reports other: smoke") in rig.station.logs


def test_allowed_requests_become_the_station_commands_they_ask_for(rig: Rig) -> None:
    for msg in (p.Goal(3), p.Pause(True), p.Pause(False), p.TourControl("resume")):
        rig.requests.on_message(msg)
    rig.requests.on_message(p.Tour(False))  # no tour runs: nothing to end
    rig.requests.on_message(p.InitialPoseRoom(2))
    assert rig.station.calls == [
        ("submit", GoTo(3), True),
        ("pause",),
        ("resume",),
        ("tour_resume",),
        ("initial_pose_room", 2),
    ]
    assert rig.errors() == []


def test_the_tablet_stop_pauses_an_operators_task_and_stops_its_own(rig: Rig) -> None:
    rig.fleet.selected.supervisor.submit(GoTo(4))  # the operator's task
    rig.fleet.selected.supervisor.update(1.0, rig.fleet.selected.supervisor.topo.nodes[0].pose)
    rig.requests.on_message(p.Stop(True))
    assert rig.station.calls == [("pause",), ("stop_tablet_speed", "stop from the tablet")]
    assert rig.errors() == ["not_owner"]
    rig.policy.adopt(rig.fleet.selected.supervisor.current_task)  # now it is the tablet's
    rig.station.calls.clear()
    rig.requests.on_message(p.Stop(True))
    assert rig.station.calls == [("stop_motion", "the tablet")]


def test_only_the_request_shown_now_can_be_answered(rig: Rig) -> None:
    rig.requests.on_message(p.RequestAnswer(1, True))
    assert rig.errors() == ["unknown_request"] and rig.station.calls == []
    rig.fleet.selected.shown_request = (1, RequestShown("coffee", 5, 2, deadline=60.0))
    rig.requests.on_message(p.RequestAnswer(1, False))
    assert rig.station.calls == [("answer_request", False)]


def test_the_operator_takes_over_stops_or_cancels_only_the_tablets_task(rig: Rig) -> None:
    rig.requests.override()
    rig.requests.stop_task()
    rig.requests.cancel_task()
    assert rig.requests.task is None and rig.station.calls == [] and rig.tablet == []
    rig.requests.on_message(p.Tour(True))
    rig.fleet.selected.supervisor.update(1.0, rig.fleet.selected.supervisor.topo.nodes[0].pose)
    assert isinstance(rig.requests.task, GuidedTour)
    rig.requests.stop_task()
    rig.requests.cancel_task()
    assert rig.station.calls[-2:] == [("pause",), ("cancel_task", "the operator")]
    assert rig.requests.override() and rig.requests.task is None
    assert rig.tablet == [p.Cancel("task taken over by the operator")]
