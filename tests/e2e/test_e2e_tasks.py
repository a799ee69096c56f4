"""End to end, tasks ordered on the Tablet (thesis §5.2.2, §6.2): a goal from the map, the
guided tour with Resume at a stop, and a request picked up in one room and delivered to another.

The robot daemon (simulated, 8x real time), the Base Station controller and the Tablet window
run in this process (tests/e2e/conftest.py); the Tablet is driven with mouse and key events and
the outcome is checked at the robot (its route and true pose) and back on the Tablet.
"""

from __future__ import annotations

from typing import Any

import pytest
from PySide6.QtTest import QTest

from robot_daemon.stack import RouteState
from tablet_app.qt_dialogs import (
    QtRequestDialog,
    QtRoomDialog,
    QtShowRequestDialog,
    QtTourStopDialog,
)

pytestmark = [pytest.mark.slow, pytest.mark.qt_log_ignore("This plugin does not support")]

ENTRANCE = 0  # Main Entrance (home), a tour stop
SECRETARIAT = 2  # the next room and tour stop: 9.5 m via the SW corner (node 1)
ISR_DOOR = 6  # the ISR Shared Experimental Area's door on the south corridor
ISR_AREA = 7  # inside that area, 4.2 m south of its door: takes requests
SERVER_ROOM = 8  # 4.7 m north of the ISR door
ARRIVAL_M = 0.35  # [m] robot's true position from the goal node (station tolerance 0.25 m)


def robot_route(rig: Any) -> RouteState | None:
    """The route the robot drives if it is the station's current one."""
    route, sent = rig.daemon.stack.route, rig.station.selected.route
    if route is None or sent is None or route.route_id != sent.route_id:
        return None
    return route


def route_to(rig: Any, node: int, state: str) -> bool:
    route = robot_route(rig)
    return route is not None and route.msg.node_ids[-1:] == (node,) and route.state == state


def test_goal_from_the_map_take_me_there(make_rig: Any) -> None:
    rig = make_rig()
    rig.localise_at(ENTRANCE)
    rig.tap_room(SECRETARIAT)
    dialog = rig.window.dialog
    assert isinstance(dialog, QtRoomDialog) and dialog.go_button.isEnabled()
    rig.click(dialog.go_button)
    assert rig.window.motion_bar.isVisible()
    assert "Secretariat" in rig.window.motion_bar.destination_label.text()

    rig.wait(lambda: route_to(rig, SECRETARIAT, "active"), 5.0, "the robot to start the route")
    route = robot_route(rig)
    assert route is not None and route.msg.node_ids == (1, SECRETARIAT)  # via the SW corner
    rig.wait(lambda: route_to(rig, SECRETARIAT, "succeeded"), 30.0, "the robot to arrive")
    goal = rig.node_pose(SECRETARIAT)
    assert rig.truth().distance_to(goal) < ARRIVAL_M
    rig.wait(
        lambda: (p := rig.station.selected.state.progress) is not None and p.reached_final,
        5.0,
        "route progress: final goal reached, at the station",
    )
    progress = rig.station.selected.state.progress
    assert progress is not None and progress.state == "succeeded"

    rig.wait(lambda: any(m.goal == SECRETARIAT and m.reached for m in rig.seen.goal_status),
             10.0, "the tablet to be told: goal reached")  # fmt: skip
    reached = [m for m in rig.seen.goal_status if m.goal == SECRETARIAT and m.reached]
    assert not reached[0].tour_reached
    assert not rig.window.motion_bar.isVisible()
    estimate = rig.daemon.stack.pose
    assert estimate is not None
    rig.wait(lambda: rig.marker_distance_px(estimate) < 6.0, 5.0, "the marker at the robot")
    assert rig.station.selected.supervisor.current_task is None


def test_guided_tour_resume_at_the_first_stop_then_end(make_rig: Any) -> None:
    rig = make_rig()
    rig.localise_at(ENTRANCE)
    rig.window.show_map()
    rig.click(rig.window.map_screen.tour_button)

    # The first stop is the one nearest the robot: the entrance, where it stands.
    rig.wait(lambda: isinstance(rig.window.dialog, QtTourStopDialog), 15.0, "the first tour stop")
    dialog = rig.window.dialog
    assert isinstance(dialog, QtTourStopDialog) and dialog.room.id == ENTRANCE
    assert rig.station.selected.supervisor.tour_stops[:2] == (ENTRANCE, SECRETARIAT)
    assert rig.station.selected.supervisor.paused  # waiting at the stop (pause lock engaged)
    rig.wait(lambda: "Pause Navigation" in rig.daemon.stack.last_output.active_locks, 5.0,
             "the robot to hold at the stop")  # fmt: skip
    # The station repeats "tour stop reached" every clock(); the tablet keeps ONE dialog.
    for _ in range(3):
        with rig.qtbot.waitSignal(rig.station.clocked, timeout=2000):
            pass
    rig.qtbot.wait(50)
    assert rig.window.dialog is dialog

    rig.click(dialog.resume_button)
    rig.wait(lambda: route_to(rig, SECRETARIAT, "active"), 5.0, "the route to the next stop")
    assert not rig.station.selected.supervisor.paused
    start = rig.truth()
    rig.wait(lambda: rig.truth().distance_to(start) > 0.5, 10.0, "the robot to head off")
    rig.wait(lambda: rig.window.map_view.room_state(SECRETARIAT) == "next", 5.0,
             "the tablet to colour the next stop")  # fmt: skip
    assert rig.window.map_view.room_state(ENTRANCE) == "visited"

    # At the second stop: End tour.
    rig.wait(
        lambda: (
            isinstance(rig.window.dialog, QtTourStopDialog)
            and rig.window.dialog.room.id == SECRETARIAT
        ),
        30.0,
        "the second tour stop",
    )
    assert rig.truth().distance_to(rig.node_pose(SECRETARIAT)) < ARRIVAL_M
    rig.click(rig.window.dialog.end_button)
    rig.wait(lambda: rig.station.selected.supervisor.current_task is None, 5.0, "the tour to end")
    assert not rig.station.selected.supervisor.paused
    assert rig.window.dialog is None
    rig.wait(lambda: "Pause Navigation" not in rig.daemon.stack.last_output.active_locks,
             5.0, "the pause lock to be released")  # fmt: skip
    # The robot settles its route at its next control cycle after the lock is released.
    rig.wait(lambda: rig.daemon.stack.route is not None
             and rig.daemon.stack.route.state == "succeeded", 5.0, "the route to succeed")  # fmt: skip
    route = rig.daemon.stack.route
    assert (
        route is not None and route.state == "succeeded" and route.msg.node_ids[-1] == SECRETARIAT
    )
    assert any(
        "tour ended by the user after 2 of" in e.text for e in rig.station.selected.state.log
    )


def test_request_picked_up_accepted_and_delivered(make_rig: Any) -> None:
    rig = make_rig(start_node=ISR_DOOR)
    rig.localise_at(ISR_DOOR)
    rig.tap_room(ISR_AREA)
    room_dialog = rig.window.dialog
    assert isinstance(room_dialog, QtRoomDialog)
    rig.click(room_dialog.request_button)
    dialog = rig.window.dialog
    assert isinstance(dialog, QtRequestDialog)
    QTest.keyClicks(dialog.text_edit, "the blue folder")
    dialog.deliver_combo.setCurrentIndex(dialog.deliver_combo.findData(SERVER_ROOM))
    rig.click(dialog.send_button)

    # The robot goes to the room ...
    rig.wait(lambda: route_to(rig, ISR_AREA, "active"), 5.0, "the route to the request room")
    rig.wait(lambda: isinstance(rig.window.dialog, QtShowRequestDialog), 30.0,
             "the tablet to show the request in the room")  # fmt: skip
    assert rig.truth().distance_to(rig.node_pose(ISR_AREA)) < ARRIVAL_M
    shown = rig.window.dialog
    assert isinstance(shown, QtShowRequestDialog)
    assert shown.request_label.text() == "the blue folder"
    assert [(r.request, r.room, r.deliver_to) for r in rig.seen.requests] == [
        ("the blue folder", ISR_AREA, SERVER_ROOM)
    ]

    # ... and, accepted, takes it to the delivery room.
    rig.click(shown.accept_button)
    rig.wait(lambda: route_to(rig, SERVER_ROOM, "active"), 5.0, "the route to the target")
    route = robot_route(rig)
    assert route is not None and route.msg.node_ids == (ISR_DOOR, SERVER_ROOM)
    rig.wait(lambda: route_to(rig, SERVER_ROOM, "succeeded"), 30.0, "the delivery")
    assert rig.truth().distance_to(rig.node_pose(SERVER_ROOM)) < ARRIVAL_M
    rig.wait(lambda: any(m.goal == SERVER_ROOM and m.reached for m in rig.seen.goal_status),
             10.0, "the tablet to be told: delivered")  # fmt: skip
    rig.wait(
        lambda: rig.station.selected.supervisor.current_task is None, 5.0, "the task to finish"
    )
    assert any("request delivered to node 8" in e.text for e in rig.station.selected.state.log)
