"""End to end, "Help me!" (thesis §5.2.2.1, Fig. 5.4): the Tablet gives the robot its pose.

The robot daemon (simulated, 8x real time), the Base Station controller and the Tablet window
run in this process (tests/e2e/conftest.py); the Tablet is driven with mouse and touch events.
"""

from __future__ import annotations

from typing import Any

import pytest
import zenoh
from PySide6.QtCore import QPoint
from PySide6.QtTest import QTest

from interbot_core.geometry import Pose2D
from interbot_core.topics import Status, Topic, decode, key
from robot_daemon.localisation.localiser import LocaliserState
from tablet_app.qt_dialogs import QtHelpConfirmDialog

pytestmark = [pytest.mark.slow, pytest.mark.qt_log_ignore("This plugin does not support")]

ENTRANCE = 0  # Main Entrance, the robot's home: where it starts
SECRETARIAT = 2  # a door on the south corridor, 8 m from the entrance
# Inside the ISR Shared Experimental Area, 28 m east of the Secretariat. A kidnap from a door
# node to another door node (facing a door across a corridor) is NOT detected by the localiser
# when the robot stands still: the wrong scan still puts 0.43-0.66 of its end points on walls,
# above its 0.35 threshold (measured from node 0 to nodes 2-5, 7-9, 13-14, 17-22; node 12 sits
# at 0.34). From the Secretariat to this room it drops to about 0.18: lost in 1.1 s.
ISR_AREA = 7
MARKER_TOLERANCE_PX = 6.0  # the map is about 14 px/m at 1280 x 800


def banner_shown(rig: Any) -> bool:
    return not rig.window.map_screen.help_banner.isHidden()


def tell_the_robot_it_is_at(rig: Any, room_id: int) -> None:
    """On the map: "Help me!" (if not helping yet), tap the room, confirm."""
    screen = rig.window.map_screen
    rig.window.show_map()
    if not screen.help_button.isHidden():
        rig.click(screen.help_button)
    assert rig.window.map_view.room_state(room_id) == "highlight"
    rig.tap_room(room_id)
    dialog = rig.window.dialog
    assert isinstance(dialog, QtHelpConfirmDialog) and dialog.room.id == room_id
    rig.click(dialog.yes_button)


def assert_localised_at(rig: Any, where: Pose2D) -> None:
    """Daemon ok near ``where`` and the truth; the station told the Tablet, whose banner is
    gone and whose marker shows the robot's pose."""
    rig.wait(lambda: rig.localisation == LocaliserState.OK, 10.0, "localisation ok")
    estimate = rig.daemon.stack.pose
    assert estimate is not None
    assert estimate.distance_to(rig.truth()) < 0.15
    assert estimate.distance_to(where) < 0.4
    rig.wait(
        lambda: (
            rig.seen.localisation[-1:] == ["ok"]
            and not banner_shown(rig)
            and rig.marker_distance_px(estimate) < MARKER_TOLERANCE_PX
        ),
        10.0,
        "the tablet: localisation ok, no Help me banner, the marker at the robot's pose",
    )
    # Stays localised (not a one-scan fluke).
    now = rig.daemon.now
    rig.wait(lambda: rig.daemon.now > now + 2.0, 5.0, "2 s of robot time")
    assert rig.localisation == LocaliserState.OK
    assert not banner_shown(rig)
    assert rig.marker_distance_px(rig.daemon.stack.pose) < MARKER_TOLERANCE_PX


def test_help_me_without_initial_pose_joystick_then_room(make_rig: Any) -> None:
    rig = make_rig()
    window, screen = rig.window, rig.window.map_screen
    assert rig.localisation == LocaliserState.UNSET
    window.show_map()
    rig.wait(lambda: banner_shown(rig), 5.0, "the tablet to show Help me")
    assert not screen.help_button.isHidden() and screen.drive_button.isHidden()
    assert window.map_view.robot_widget_pos() is None  # no pose, no marker

    rig.click(screen.help_button)
    assert screen.help_button.isHidden() and not screen.drive_button.isHidden()
    assert window.map_view.room_state(ENTRANCE) == "highlight"

    # Drive a little (a few centimetres forward, i.e. west) with the joystick.
    rig.click(screen.drive_button)
    assert window.stack.currentWidget() is window.joystick_screen
    joystick = window.joystick_screen.joystick
    start = rig.truth()
    device = QTest.createTouchDevice()
    point = joystick.center().toPoint() + QPoint(0, -round(joystick.radius() * 0.25))
    rig.touch(joystick, device, "press", point)
    rig.wait(lambda: rig.daemon.stack.last_output.source == "Tablet", 5.0, "tablet_vel to drive")
    rig.wait(lambda: rig.truth().distance_to(start) > 0.03, 5.0, "the robot to move")
    rig.touch(joystick, device, "release", point)
    rig.wait(
        lambda: (
            rig.daemon.stack.last_output.linear == 0.0
            and rig.backend.sim.true_velocity() == (0.0, 0.0)
        ),
        5.0,
        "the robot to stop after the release",
    )
    moved = rig.truth()
    assert moved.x < start.x  # node 0 faces west: forward is -x
    assert 0.03 < moved.distance_to(start) < 0.25
    assert rig.localisation == LocaliserState.UNSET  # driving does not localise

    rig.click(window.joystick_screen.back_button)
    assert window.stack.currentWidget() is screen  # back to the map while helping
    tell_the_robot_it_is_at(rig, ENTRANCE)
    assert_localised_at(rig, rig.node_pose(ENTRANCE))
    assert any("initial pose set" in e.text for e in rig.station.selected.state.log)


def test_help_me_after_a_kidnap(make_rig: Any) -> None:
    rig = make_rig(start_node=SECRETARIAT)
    rig.localise_at(SECRETARIAT)
    rig.window.show_map()
    assert not banner_shown(rig)
    kidnap = rig.node_pose(ISR_AREA)
    assert kidnap.distance_to(rig.truth()) > 5.0

    # The robot's own stamp of its "localisation lost" status line: the robot time at which it
    # said so. (Reading the robot's clock when this thread saw the state added the Qt thread's
    # lag times the realtime factor, 8: 100 ms of a loaded machine's scheduling = 0.8 s.)
    lost_stamps: list[float] = []

    def on_status(sample: zenoh.Sample) -> None:
        status = decode(Topic.STATUS, sample.payload.to_bytes())
        if isinstance(status, Status) and status.text == "localisation lost":
            lost_stamps.append(status.stamp)

    probe = rig.station.link.session.declare_subscriber(
        key(rig.station.selected_robot, Topic.STATUS), on_status
    )
    kidnapped_at = rig.teleport(kidnap)
    rig.wait(lambda: rig.localisation == LocaliserState.LOST, 10.0, "the daemon to report lost")
    rig.wait(lambda: bool(lost_stamps), 10.0, "the robot's status line: localisation lost")
    probe.undeclare()
    assert 0.0 < lost_stamps[0] - kidnapped_at < 2.5  # lost within about 2 s of robot time
    rig.wait(lambda: "lost" in rig.seen.localisation, 5.0, "the tablet to be told: lost")
    rig.wait(lambda: banner_shown(rig), 5.0, "the tablet to show Help me")
    assert rig.station.selected.state.localisation == "lost"
    assert rig.daemon.stack.last_output.linear == 0.0

    tell_the_robot_it_is_at(rig, ISR_AREA)
    assert_localised_at(rig, kidnap)
    assert rig.seen.localisation[-1] == "ok"
