"""The Tablet window driven by real mouse, key and touch events against a fake Base Station.

Every action is checked by the EXACT JSON object the station receives; every station message by
what the window shows.
"""

from __future__ import annotations

from typing import Any

import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtTest import QTest

from interbot_core.joystick import joystick_command
from interbot_core.protocol import (
    Cancel,
    GoalStatus,
    InitialPose,
    Localisation,
    Pose,
    SafetyInfo,
    ShowRequest,
    StatusInfo,
    TourState,
)
from tablet_app.qt_dialogs import (
    QtHelpConfirmDialog,
    QtMalfunctionDialog,
    QtRequestDialog,
    QtRoomDialog,
    QtShowRequestDialog,
    QtTourStopDialog,
)

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")


def commands(station: Any) -> list[dict[str, Any]]:
    """What the tablet sent, without pings and without the speed stamps (``seq``, ``t``)."""
    out = []
    for obj in station.received:
        if {"ping", "pong"} & obj.keys():
            continue
        if isinstance(obj.get("speed"), dict):
            obj = {"speed": {k: v for k, v in obj["speed"].items() if k not in ("seq", "t")}}
        out.append(obj)
    return out


def speed_stamps(station: Any) -> list[tuple[int, float]]:
    return [(o["speed"]["seq"], o["speed"]["t"]) for o in station.received if "speed" in o]


def click(widget: Any) -> None:
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)


def wait_sent(qtbot: Any, station: Any, expected: list[dict[str, Any]]) -> None:
    """Wait until the tablet's commands after hello equal ``expected`` exactly."""
    qtbot.waitUntil(lambda: commands(station)[1:] == expected)


def tap_room(window: Any, room_id: int) -> None:
    window.show_map()
    click(window.map_view.room_button(room_id))


def test_hello_then_nothing_else_but_pings(qtbot: Any, station: Any, window: Any) -> None:
    assert commands(station) == [{"hello": {"protocol": 1, "client": "tablet"}}]


def test_room_tap_opens_info_and_take_me_there_sends_goal(
    qtbot: Any, station: Any, window: Any
) -> None:
    tap_room(window, 4)
    dialog = window.dialog
    assert isinstance(dialog, QtRoomDialog)
    assert dialog.info_label.text() == "The director's office."
    click(dialog.go_button)
    wait_sent(qtbot, station, [{"goal": 4}])
    assert window.motion_bar.isVisible()
    assert "Office" in window.motion_bar.destination_label.text()


def test_door_and_inside_nodes_share_one_target_mapped_to_the_request_node(
    qtbot: Any, station: Any, window: Any
) -> None:
    tap_room(window, 3)
    click(window.dialog.go_button)
    wait_sent(qtbot, station, [{"goal": 3}])
    with pytest.raises(KeyError):
        window.map_view.room_button(2)  # the door node has no button of its own
    with pytest.raises(KeyError):
        window.map_view.room_button(1)  # a corridor waypoint is not a room


def test_pause_resume_cancel_and_manual_control(qtbot: Any, station: Any, window: Any) -> None:
    window.go_to(0)
    bar = window.motion_bar
    click(bar.pause_button)
    wait_sent(qtbot, station, [{"goal": 0}, {"pause": True}])
    assert bar.resume_button.isEnabled() and not bar.pause_button.isEnabled()
    click(bar.resume_button)
    wait_sent(qtbot, station, [{"goal": 0}, {"pause": True}, {"pause": False}])
    click(bar.manual_button)
    assert window.stack.currentWidget() is window.joystick_screen
    click(bar.cancel_button)
    wait_sent(qtbot, station, [{"goal": 0}, {"pause": True}, {"pause": False}, {"stop": True}])
    assert not bar.isVisible()


def test_tour_and_home_buttons(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    click(window.map_screen.tour_button)
    click(window.map_screen.home_button)
    window.show_menu()
    click(window.menu.home_button)
    wait_sent(qtbot, station, [{"tour": True}, {"home": True}, {"home": True}])


def test_request_dialog_sends_request_from(qtbot: Any, station: Any, window: Any) -> None:
    tap_room(window, 4)
    room_dialog = window.dialog
    assert room_dialog.request_button.isVisible()
    click(room_dialog.request_button)
    dialog = window.dialog
    assert isinstance(dialog, QtRequestDialog)
    assert not dialog.send_button.isEnabled()
    QTest.keyClicks(dialog.text_edit, "the blue folder")
    dialog.deliver_combo.setCurrentIndex(dialog.deliver_combo.findData(0))
    click(dialog.send_button)
    wait_sent(
        qtbot,
        station,
        [
            {
                "requestFrom": {
                    "request": "the blue folder",
                    "room": 4,
                    "deliverTo": 0,
                    "status": True,
                }
            }
        ],
    )


def test_entrance_has_no_request_button(qtbot: Any, station: Any, window: Any) -> None:
    tap_room(window, 0)
    assert not window.dialog.request_button.isVisible()


def test_pose_moves_the_robot_marker(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    station.send(Pose(3.0, 4.0, 1.0))
    qtbot.waitUntil(lambda: window.map_view.robot_widget_pos() is not None)
    pos = window.map_view.robot_widget_pos()
    expected = window.map_view.transform.world_to_widget(3.0, 4.0)
    assert (pos.x(), pos.y()) == pytest.approx(expected)
    # The Office spans x 2..5, y 3..5: the marker lies inside its button.
    assert window.map_view.room_button(4).geometry().contains(pos.toPoint())
    # Grab the frame to make sure the painted marker is red there.
    image = window.map_view.grab().toImage()
    colour = image.pixelColor(pos.toPoint())
    assert colour.red() > 200 and colour.green() < 60


def test_tour_state_colours_visited_green_and_next_red(
    qtbot: Any, station: Any, window: Any
) -> None:
    window.show_map()
    station.send(TourState((0, 3, 4), (0,), 3))
    view = window.map_view
    qtbot.waitUntil(lambda: view.room_state(3) == "next")
    assert view.room_state(0) == "visited"
    assert view.room_state(4) == "normal"
    image = view.grab().toImage()
    visited = image.pixelColor(view.room_rect(0).center().toPoint() + QPoint(0, 12))
    nxt = image.pixelColor(view.room_rect(3).center().toPoint() + QPoint(0, 25))
    assert visited.green() > visited.red()
    assert nxt.red() > nxt.green()


def test_goal_status_drives_the_motion_bar(qtbot: Any, station: Any, window: Any) -> None:
    station.send(Pose(1.0, 1.0, 0.0))
    station.send(GoalStatus(4, False, False))
    qtbot.waitUntil(lambda: window.motion_bar.isVisible())
    station.send(Pose(2.0, 2.5, 0.0))  # half-way (distance 3.6 m -> 1.8 m)
    qtbot.waitUntil(lambda: window.motion_bar.progress.value() == 50)
    station.send(GoalStatus(4, True, False))
    qtbot.waitUntil(lambda: not window.motion_bar.isVisible())
    assert "Office" in window.status_label.text()


def test_tour_stop_dialog_sends_tour_control(qtbot: Any, station: Any, window: Any) -> None:
    station.send(GoalStatus(3, True, True))
    qtbot.waitUntil(lambda: isinstance(window.dialog, QtTourStopDialog))
    assert window.dialog.info_label.text() == "Robots are built here."
    click(window.dialog.resume_button)
    station.send(GoalStatus(4, True, True))
    qtbot.waitUntil(
        lambda: isinstance(window.dialog, QtTourStopDialog) and window.dialog.room.id == 4
    )
    click(window.dialog.end_button)
    wait_sent(qtbot, station, [{"tour_control": "resume"}, {"tour_control": "end"}])


def test_show_request_accept_then_status(qtbot: Any, station: Any, window: Any) -> None:
    station.send(ShowRequest(9, "sign this form", 4, 0))
    qtbot.waitUntil(lambda: isinstance(window.dialog, QtShowRequestDialog))
    dialog = window.dialog
    assert dialog.request_label.text() == "sign this form"
    click(dialog.accept_button)
    wait_sent(qtbot, station, [{"request_answer": {"id": 9, "accepted": True}}])
    assert "I am taking it to Entrance" in dialog.status_label.text()
    station.send(StatusInfo("request 9", "on the way to Entrance"))
    qtbot.waitUntil(lambda: dialog.status_label.text() == "on the way to Entrance")


def test_show_request_decline(qtbot: Any, station: Any, window: Any) -> None:
    station.send(ShowRequest(2, "lend me a pen", 0, 4))
    qtbot.waitUntil(lambda: isinstance(window.dialog, QtShowRequestDialog))
    click(window.dialog.decline_button)
    wait_sent(qtbot, station, [{"request_answer": {"id": 2, "accepted": False}}])
    assert window.dialog is None


def test_help_me_flow_sends_initial_pose_room(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    screen = window.map_screen
    assert not screen.help_banner.isVisible()
    station.send(InitialPose(False))
    qtbot.waitUntil(lambda: screen.help_banner.isVisible())
    click(screen.help_button)
    assert window.map_view.room_state(4) == "highlight"
    click(screen.drive_button)
    assert window.stack.currentWidget() is window.joystick_screen
    click(window.joystick_screen.back_button)
    assert window.stack.currentWidget() is screen
    click(window.map_view.room_button(4))
    assert isinstance(window.dialog, QtHelpConfirmDialog)
    click(window.dialog.yes_button)
    wait_sent(qtbot, station, [{"initial_pose_room": 4}])
    # Sent is not confirmed: no "Thank you" until the robot says it is localised.
    assert screen.help_banner.isVisible() and "Checking" in screen.help_text.text()
    assert "Thank you" not in window.status_label.text()
    assert window.map_view.room_state(4) == "normal"
    station.send(Localisation("ok"))
    qtbot.waitUntil(lambda: not screen.help_banner.isVisible())
    assert window.status_label.text() == "Thank you! I am at Office."


def test_localisation_lost_offers_help(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    station.send(Localisation("lost"))
    qtbot.waitUntil(lambda: window.map_screen.help_banner.isVisible())
    station.send(Localisation("ok"))
    qtbot.waitUntil(lambda: not window.map_screen.help_banner.isVisible())


def test_joystick_screen_shows_the_collision_monitor(qtbot: Any, station: Any, window: Any) -> None:
    window.show_joystick()
    label = window.joystick_screen.monitor_label
    station.send(SafetyInfo("stop", 0.04, True))
    qtbot.waitUntil(lambda: "Stopped" in label.text())
    assert "4 cm" in label.text() and "assistance on" in label.text()
    station.send(SafetyInfo("none", 1000.0, False))
    qtbot.waitUntil(lambda: label.text() == "Path clear")


def test_malfunction_report(qtbot: Any, station: Any, window: Any) -> None:
    click(window.menu.malfunction_button)
    dialog = window.dialog
    assert isinstance(dialog, QtMalfunctionDialog)
    click(dialog.kind_buttons["wrong_orientation"])
    QTest.keyClicks(dialog.text_edit, "facing the wall")
    click(dialog.send_button)
    wait_sent(
        qtbot, station, [{"malfunction": {"kind": "wrong_orientation", "text": "facing the wall"}}]
    )


def test_cancel_from_the_operator_closes_dialogs(qtbot: Any, station: Any, window: Any) -> None:
    window.go_to(4)
    tap_room(window, 0)
    station.send(Cancel("cancelled by the operator"))
    qtbot.waitUntil(lambda: window.dialog is None)
    assert not window.motion_bar.isVisible()


def touch(widget: Any, device: Any, action: str, point: QPoint) -> None:
    """One committed touch event at ``point`` (widget coordinates), sent through the window.

    QTest's widget overload maps the point as if the top-level window sat at (0, 0); the
    offscreen platform places it at (2, 2), so it would land 2 px off. The QWindow overload maps
    correctly.
    """
    sequence = QTest.touchEvent(widget.window().windowHandle(), device, autoCommit=False)
    getattr(sequence, action)(0, widget.mapTo(widget.window(), point))
    sequence.commit()


def _expected_speed(joystick: Any, point: QPoint) -> dict[str, Any]:
    c = joystick.center()
    linear, angular = joystick_command(
        c.x(),
        c.y(),
        point.x(),
        point.y(),
        joystick.radius(),
        joystick.state.linear_max,
        joystick.state.angular_max,
    )
    return {"speed": {"linear": round(linear, 3) + 0.0, "angular": round(angular, 3) + 0.0}}


def test_joystick_touch_sends_speeds_every_100ms_and_zero_on_release(
    qtbot: Any, station: Any, window: Any
) -> None:
    click(window.menu.joystick_button)
    screen = window.joystick_screen
    joystick = screen.joystick
    click(screen.linear_up)  # 0.3 m/s is the most the robot allows the tablet
    assert joystick.state.linear_max == pytest.approx(0.3)
    click(screen.linear_down)  # 0.3 -> 0.2 m/s
    assert joystick.state.linear_max == pytest.approx(0.2)
    c = joystick.center().toPoint()
    r = joystick.radius()
    inside = c + QPoint(-round(r * 0.3), -round(r * 0.5))
    outside = QPoint(c.x() + round(r * 0.9), c.y() + round(r * 0.9))  # beyond the circle
    device = QTest.createTouchDevice()
    station.clear()
    touch(joystick, device, "press", inside)
    first = _expected_speed(joystick, inside)
    assert first["speed"]["linear"] > 0 and first["speed"]["angular"] > 0
    qtbot.waitUntil(lambda: commands(station)[:1] == [first])
    qtbot.waitUntil(lambda: len(commands(station)) >= 3)  # the 100 ms timer repeats it
    assert all(cmd == first for cmd in commands(station))
    touch(joystick, device, "move", outside)
    edge = _expected_speed(joystick, outside)
    assert edge["speed"]["linear"] == pytest.approx(-0.2 * 2**-0.5, abs=2e-3)
    assert edge["speed"]["angular"] == pytest.approx(-0.6 * 2**-0.5, abs=2e-3)
    qtbot.waitUntil(lambda: edge in commands(station))
    touch(joystick, device, "release", outside)
    zero = {"speed": {"linear": 0.0, "angular": 0.0}}
    qtbot.waitUntil(lambda: commands(station)[-1] == zero)
    assert not screen._timer.isActive()
    assert commands(station).count(zero) == 1
    stamps = speed_stamps(station)  # every command numbered and stamped, in order
    assert [seq for seq, _ in stamps] == sorted({seq for seq, _ in stamps})
    assert [t for _, t in stamps] == sorted(t for _, t in stamps)


def test_joystick_mouse_drag(qtbot: Any, station: Any, window: Any) -> None:
    window.show_joystick()
    joystick = window.joystick_screen.joystick
    c = joystick.center().toPoint()
    point = c + QPoint(0, -round(joystick.radius() / 2))
    station.clear()
    QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=point)
    expected = _expected_speed(joystick, point)
    assert expected["speed"]["linear"] == pytest.approx(0.15, abs=0.002)  # half of 0.3 m/s
    assert expected["speed"]["angular"] == 0.0
    qtbot.waitUntil(lambda: commands(station)[:1] == [expected])
    QTest.mouseRelease(joystick, Qt.MouseButton.LeftButton, pos=point)
    qtbot.waitUntil(lambda: commands(station)[-1] == {"speed": {"linear": 0.0, "angular": 0.0}})


def test_lossy_warning_appears_when_pongs_stop(qtbot: Any, station: Any, window: Any) -> None:
    window.show_joystick()
    warning = window.joystick_screen.warning_label
    qtbot.waitUntil(lambda: window.connection.average_latency_ms is not None)
    assert not warning.isVisible()
    assert "ms" in window.joystick_screen.latency_label.text()
    station.answer_pings = False
    qtbot.waitUntil(warning.isVisible, timeout=10_000)
    assert "not be obeyed" in warning.text()


def test_disconnect_is_shown_and_reconnect_happens(qtbot: Any, station: Any, window: Any):
    port = station.port
    station.close()
    qtbot.waitUntil(lambda: "reconnecting" in window.connection_label.text())
    station.listen(port)
    qtbot.waitUntil(lambda: "Connected" in window.menu.connection_label.text(), timeout=10_000)


def test_language_switch_to_portuguese_and_back(qtbot: Any, station: Any, window: Any) -> None:
    assert window.menu.map_button.text() == "Map"
    click(window.menu.portuguese_button)
    qtbot.waitUntil(lambda: window.menu.map_button.text() == "Mapa")
    assert window.menu.malfunction_button.text() == "Reportar uma avaria"
    assert window.motion_bar.pause_button.text() == "Pausa"
    click(window.menu.english_button)
    qtbot.waitUntil(lambda: window.menu.map_button.text() == "Map")


def test_touch_targets_are_at_least_9_mm(qtbot: Any, station: Any, window: Any) -> None:
    dpi = window.logicalDpiX()
    min_px = 9.0 / 25.4 * dpi
    for button in (window.menu.map_button, window.motion_bar.pause_button):
        assert button.minimumHeight() >= min_px
    for room in window.plan.rooms:
        geometry = window.map_view.room_button(room.id).geometry()
        assert min(geometry.width(), geometry.height()) >= min_px


def test_kiosk_fills_the_whole_screen(qtbot: Any, station: Any, window: Any) -> None:
    """Full screen is the screen's geometry, frameless (no window manager is needed for it)."""
    from PySide6.QtCore import Qt
    from PySide6.QtGui import QGuiApplication

    from tablet_app.main import show_kiosk

    window.resize(660, 450)
    show_kiosk(window, screen_index=7)  # no such screen: the primary, with a warning logged
    screen = QGuiApplication.primaryScreen().geometry()
    qtbot.waitUntil(lambda: window.geometry().size() == screen.size())
    assert window.isFullScreen()
    assert window.windowFlags() & Qt.WindowType.FramelessWindowHint
    assert window.kiosk
    window.kiosk = False  # let the fixture close it


def test_kiosk_closes_only_after_the_operator_gesture(
    qtbot: Any, station: Any, window: Any
) -> None:
    from PySide6.QtWidgets import QMessageBox

    from tablet_app.kiosk import TAPS

    window.kiosk = True
    window.close()
    assert window.isVisible()  # a close request is ignored
    for _ in range(TAPS - 1):
        QTest.mouseClick(window.connection_label, Qt.MouseButton.LeftButton, pos=QPoint(5, 5))
    assert not hasattr(window, "exit_box")
    QTest.mouseClick(window.connection_label, Qt.MouseButton.LeftButton, pos=QPoint(5, 5))
    qtbot.waitUntil(lambda: hasattr(window, "exit_box") and window.exit_box.isVisible())
    click(window.exit_box.button(QMessageBox.StandardButton.Yes))
    qtbot.waitUntil(lambda: not window.isVisible())


def test_exit_gesture_needs_the_taps_close_together() -> None:
    from tablet_app.kiosk import ExitGesture

    gesture = ExitGesture(taps=3, window_s=1.0)
    assert not any(gesture.tap(t) for t in (0.0, 0.6, 1.2))  # too slow
    assert [gesture.tap(t) for t in (2.0, 2.3, 2.6)] == [False, False, True]


def test_the_header_names_the_robot_welcomed_then_the_one_switched_to(
    qtbot: Any, station: Any, window: Any
) -> None:
    """Issue 14: the operator switches robots; the tablet's header follows (no stale name)."""
    from interbot_core.protocol import RobotName, Welcome

    qtbot.waitUntil(lambda: window.connection.is_connected)
    station.send(Welcome(1, "bot1"))
    qtbot.waitUntil(lambda: "bot1" in window.connection_label.text())
    assert window.session.robot == "bot1" and window.connection.robot_name == "bot1"
    station.send(RobotName("bot4"))
    qtbot.waitUntil(lambda: "bot4" in window.connection_label.text())
    assert "bot1" not in window.connection_label.text()
    assert "bot4" in window.menu.connection_label.text() and window.session.robot == "bot4"
