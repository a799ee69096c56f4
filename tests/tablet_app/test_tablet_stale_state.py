"""The tablet's stale-state defects found with real clicks (issue: "a product people enjoy").

Each test drives the real window with mouse clicks against a fake Base Station on loopback and
checks what is on screen. Each failed on the window that kept robot state in its widgets.
"""

from __future__ import annotations

from typing import Any

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest

from interbot_core.protocol import (
    ErrorReport,
    GoalStatus,
    InitialPose,
    Localisation,
    StatusInfo,
    TourState,
)
from tablet_app.qt_dialogs import QtHelpConfirmDialog, QtTourStopDialog

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")


def click(widget: Any) -> None:
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)


def at_tour_stop(qtbot: Any, station: Any, window: Any) -> None:
    station.send(TourState((0, 3, 4), (0,), 3))
    station.send(GoalStatus(3, True, True))
    qtbot.waitUntil(lambda: isinstance(window.dialog, QtTourStopDialog))
    assert window.map_view.room_state(0) == "visited"
    assert window.map_view.room_state(3) == "next"


def test_end_tour_clears_the_tour_highlight(qtbot: Any, station: Any, window: Any) -> None:
    at_tour_stop(qtbot, station, window)
    click(window.dialog.end_button)
    qtbot.waitUntil(lambda: bool(station.messages("tour_control")))
    assert window.dialog is None
    assert window.map_view.room_state(0) == "normal"
    assert window.map_view.room_state(3) == "normal"
    assert window.status_label.text() == "The guided tour has ended."


def test_station_restart_clears_tour_highlight_and_dialog(
    qtbot: Any, station: Any, window: Any
) -> None:
    at_tour_stop(qtbot, station, window)
    hellos = len(station.messages("hello"))
    station.drop_client()  # the station restarts; the tablet reconnects by itself
    qtbot.waitUntil(lambda: len(station.messages("hello")) > hellos, timeout=5000)
    qtbot.waitUntil(lambda: window.dialog is None)
    assert window.map_view.room_state(0) == "normal"
    assert window.map_view.room_state(3) == "normal"


def test_going_to_bar_stays_gone_after_cancel(qtbot: Any, station: Any, window: Any) -> None:
    window.go_to(4)
    station.send(GoalStatus(4, False, False))
    qtbot.waitUntil(lambda: window.motion_bar.isVisible())
    click(window.motion_bar.cancel_button)
    qtbot.waitUntil(lambda: bool(station.messages("stop")))
    assert not window.motion_bar.isVisible()
    for _ in range(3):  # repeats the station sent before it saw the cancel
        station.send(GoalStatus(4, False, False))
    station.send(StatusInfo("idle", "idle"))
    qtbot.wait(300)
    assert not window.motion_bar.isVisible()
    assert window.status_label.text() == "Cancelled. I have stopped."


def test_refused_help_pose_never_says_thank_you(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    station.send(InitialPose(False))
    qtbot.waitUntil(lambda: window.map_screen.help_banner.isVisible())
    click(window.map_screen.help_button)
    click(window.map_view.room_button(4))
    assert isinstance(window.dialog, QtHelpConfirmDialog)
    click(window.dialog.yes_button)
    qtbot.waitUntil(lambda: bool(station.messages("initial_pose_room")))
    station.send(ErrorReport("bad_pose", "the scan does not match Office"))
    qtbot.waitUntil(lambda: "could not confirm" in window.status_label.text())
    assert "Thank you" not in window.status_label.text()
    assert window.map_screen.help_banner.isVisible()
    assert window.map_screen.drive_button.isVisible()  # asked to try again
    station.send(Localisation("lost"))
    qtbot.wait(100)
    assert "Thank you" not in window.status_label.text()


def test_arrived_is_not_overwritten_by_idle(qtbot: Any, station: Any, window: Any) -> None:
    window.go_to(4)
    station.send(GoalStatus(4, False, False))
    qtbot.waitUntil(lambda: window.motion_bar.isVisible())
    station.send(GoalStatus(4, True, False))
    qtbot.waitUntil(lambda: not window.motion_bar.isVisible())
    station.send(StatusInfo("idle", "idle"))
    qtbot.waitUntil(lambda: window.activity_label.text() == "Ready")
    assert window.status_label.text() == "Arrived at Office."


def test_help_is_offered_on_every_screen(qtbot: Any, station: Any, window: Any) -> None:
    station.send(Localisation("lost"))
    qtbot.waitUntil(lambda: window.help_button.isVisible())
    window.show_joystick()
    assert window.help_button.isVisible()
    click(window.help_button)
    assert window.stack.currentWidget() is window.map_screen
    assert window.map_screen.drive_button.isVisible()  # straight into choosing a room


def test_greyed_out_buttons_say_why(qtbot: Any, station: Any, window: Any) -> None:
    from interbot_core.protocol import Permissions

    assert not window.unavailable_label.isVisible()
    station.send(Permissions(False, True, False, True))
    qtbot.waitUntil(lambda: window.unavailable_label.isVisible())
    assert window.unavailable_label.text() == (
        "Not available now: driving with the joystick, guided tours"
    )
    assert not window.menu.joystick_button.isEnabled()
    station.send(Permissions(True, True, True, True))
    qtbot.waitUntil(lambda: not window.unavailable_label.isVisible())
