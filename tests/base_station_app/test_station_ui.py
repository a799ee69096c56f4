"""The main window with real QTest mouse and key events: teleop keys and pad, focus loss, e-stop
buttons, room clicks and pose picks on the map, the task queue, configuration (station file) and QSettings (window state)."""

from __future__ import annotations

import math
import socket
from pathlib import Path

import pytest
import yaml
from PySide6.QtCore import QEvent, QPoint, QPointF, QSettings, Qt
from PySide6.QtGui import QFocusEvent
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QWidget

from base_station_app.main_window import TAB_NAMES, MainWindow
from base_station_app.station_controller import StationController
from base_station_app.station_file import StationSettingsStore
from interbot_core.geometry import Pose2D
from interbot_core.supervisor import GoTo, GoToPose
from interbot_core.topics import InitialPose, Lock, StopRelease, Topic
from tests.base_station_app.conftest import robot_arrives

TOPO_PATH = Path(__file__).resolve().parents[2] / "maps" / "isr_floor0_topo.yaml"

# The offscreen platform warns once per shown top-level window; nothing to fix on our side.
pytestmark = pytest.mark.qt_log_ignore("propagateSizeHints")


@pytest.fixture
def settings(tmp_path) -> QSettings:
    return QSettings(str(tmp_path / "station_test.ini"), QSettings.Format.IniFormat)


@pytest.fixture
def window(qtbot, station, settings) -> MainWindow:
    w = MainWindow(station, settings)
    qtbot.addWidget(w)
    w.resize(1400, 900)
    w.show()
    qtbot.waitExposed(w)
    w.activateWindow()
    qtbot.waitUntil(w.isActiveWindow, timeout=10_000)
    w.map_view.setFocus()
    qtbot.waitUntil(w.map_view.hasFocus, timeout=10_000)
    return w


def view_pos(window: MainWindow, x: float, y: float) -> QPoint:
    """Viewport pixel of map point (x, y) [m]."""
    view = window.map_view
    scene = view.getPlotItem().vb.mapViewToScene(QPointF(x, y))
    return view.mapFromScene(scene)


def test_window_has_every_tab_and_a_map(window, station):
    assert [window.tabs.tabText(i).lower() for i in range(window.tabs.count())] == list(TAB_NAMES)
    image = window.map_view.map_item.image
    assert image is not None and image.dtype.name == "uint8"
    assert image.shape == station.grid.cells.shape


def test_arrow_keys_on_the_map_drive_and_stop(qtbot, linked, window, robot, clock):
    view = window.map_view
    QTest.keyPress(view, Qt.Key.Key_Up)
    QTest.keyPress(
        view, Qt.Key.Key_Up, Qt.KeyboardModifier.NoModifier
    )  # a second press is harmless
    clock.advance(0.1)
    linked.tick()
    QTest.keyPress(view, Qt.Key.Key_A)
    clock.advance(0.1)
    linked.tick()
    QTest.keyRelease(view, Qt.Key.Key_Up)
    QTest.keyRelease(view, Qt.Key.Key_A)
    # press, press again, tick, press A, tick, release Up, release A (zero)
    qtbot.waitUntil(lambda: len(robot.of("station_vel")) == 7, timeout=10_000)
    v = [(t.linear, t.angular) for t in robot.of("station_vel")]
    lin, ang = linked.config.teleop_linear_max, linked.config.teleop_angular_max
    assert v == [(lin, 0.0)] * 3 + [(lin, ang)] * 2 + [(0.0, ang), (0.0, 0.0)]


def test_focus_loss_sends_zero(qtbot, linked, window, robot):
    view = window.map_view
    QTest.keyPress(view, Qt.Key.Key_W)
    assert linked.arbiter.keys.active
    QApplication.sendEvent(view, QFocusEvent(QEvent.Type.FocusOut))
    assert not linked.arbiter.keys.active
    qtbot.waitUntil(lambda: len(robot.of("station_vel")) == 2, timeout=10_000)
    assert robot.of("station_vel")[-1].linear == 0.0
    QTest.keyPress(view, Qt.Key.Key_S)
    window.activateWindow()
    qtbot.waitUntil(window.isActiveWindow, timeout=10_000)
    other = QWidget()
    qtbot.addWidget(other)
    other.show()
    other.activateWindow()  # the station window loses activation (changeEvent)
    qtbot.waitUntil(lambda: not window.isActiveWindow(), timeout=10_000)
    assert not linked.arbiter.keys.active


def test_arrow_pad_buttons_press_and_release(qtbot, linked, window, robot):
    from base_station_app.teleop import Direction

    button = window.teleop_panel.pad[Direction.RIGHT]
    assert not button.autoRepeat()
    QTest.mousePress(button, Qt.MouseButton.LeftButton)
    assert linked.arbiter.keys.command() == (0.0, -linked.config.teleop_angular_max)
    QTest.mouseRelease(button, Qt.MouseButton.LeftButton)
    assert not linked.arbiter.keys.active
    qtbot.waitUntil(lambda: len(robot.of("station_vel")) == 2, timeout=10_000)


def test_mouse_joystick_drives(qtbot, linked, window, robot):
    window.tabs.setCurrentIndex(TAB_NAMES.index("teleop"))
    joy = window.teleop_panel.joystick
    qtbot.waitExposed(joy)
    centre = joy.rect().center()
    QTest.mousePress(
        joy, Qt.MouseButton.LeftButton, pos=QPoint(centre.x(), centre.y() - int(joy.radius() / 2))
    )
    assert linked.arbiter.keys.active
    lin, _ = linked.arbiter.keys.command()
    assert lin == pytest.approx(linked.config.teleop_linear_max / 2, rel=0.05)
    QTest.mouseRelease(joy, Qt.MouseButton.LeftButton, pos=centre)
    assert not linked.arbiter.keys.active


def test_estop_buttons_latch_and_release(qtbot, linked, window, robot, clock):
    panel = window.teleop_panel
    assert not panel.release_button.isEnabled()
    QTest.mouseClick(panel.estop_button, Qt.MouseButton.LeftButton)
    assert panel.release_button.isEnabled()
    assert not panel.joystick.isEnabled()
    qtbot.waitUntil(lambda: robot.of("stop") == [Lock(True, stamp=clock.now)], timeout=10_000)
    QTest.mouseClick(panel.release_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: len(robot.of("stop_release")) == 1, timeout=10_000)
    assert isinstance(robot.of("stop_release")[0], StopRelease)
    assert not panel.release_button.isEnabled()


def test_click_room_on_map_then_move_there(qtbot, window, station, topo):
    room = station.rooms.room(5)
    cx, cy = room.label
    assert station.rooms.room_at(cx, cy).id == 5
    with qtbot.waitSignal(window.map_view.room_clicked) as blocker:
        QTest.mouseClick(
            window.map_view.viewport(), Qt.MouseButton.LeftButton, pos=view_pos(window, cx, cy)
        )
    assert blocker.args == [5]
    QTest.mouseClick(window.task_panel.goto_button, Qt.MouseButton.LeftButton)
    assert station.selected.supervisor.queue == (GoTo(5),)


def drag(window, a: tuple[float, float], b: tuple[float, float]) -> None:
    vp = window.map_view.viewport()
    QTest.mousePress(vp, Qt.MouseButton.LeftButton, pos=view_pos(window, *a))
    QTest.mouseMove(vp, view_pos(window, (a[0] + b[0]) / 2, (a[1] + b[1]) / 2))
    QTest.mouseMove(vp, view_pos(window, *b))
    QTest.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=view_pos(window, *b))


def test_goal_by_click_and_drag(qtbot, window, station):
    QTest.mouseClick(window.task_panel.goal_pick_button, Qt.MouseButton.LeftButton)
    assert window.statusBar().currentMessage().startswith("click the goal on the map")
    assert window.map_view.cursor().shape() == Qt.CursorShape.CrossCursor
    with qtbot.waitSignal(window.map_view.pose_picked) as blocker:
        drag(window, (0.0, 0.0), (0.0, 5.0))
    mode, pose = blocker.args
    assert mode == "goal"
    assert (pose.x, pose.y) == pytest.approx((0.0, 0.0), abs=0.2)
    assert pose.yaw == pytest.approx(math.pi / 2, abs=0.1)
    (task,) = station.selected.supervisor.queue
    assert isinstance(task, GoToPose) and task.pose == pose
    assert window.map_view.cursor().shape() == Qt.CursorShape.ArrowCursor  # picked: back to panning


def test_initial_pose_arrow_reaches_robot(qtbot, linked, window, robot):
    QTest.mouseClick(window.task_panel.initial_pick_button, Qt.MouseButton.LeftButton)
    drag(window, (-10.0, 2.0), (-14.0, 2.0))
    qtbot.waitUntil(lambda: len(robot.of("initial_pose")) == 1, timeout=10_000)
    msg = robot.of("initial_pose")[0]
    assert isinstance(msg, InitialPose)
    assert (msg.x, msg.y) == pytest.approx((-10.0, 2.0), abs=0.2)
    assert abs(abs(msg.yaw) - math.pi) < 0.1


def test_queue_reorder_and_cancel_buttons(qtbot, window, station, localise, topo):
    for node in (3, 5, 9):
        station.submit(GoTo(node))
    panel = window.task_panel
    assert panel.queue_list.count() == 3
    panel.queue_list.setCurrentRow(2)
    QTest.mouseClick(panel.up_button, Qt.MouseButton.LeftButton)
    assert station.selected.supervisor.queue == (GoTo(3), GoTo(9), GoTo(5))
    assert panel.queue_list.currentRow() == 1
    panel.queue_list.setCurrentRow(0)
    QTest.mouseClick(panel.remove_button, Qt.MouseButton.LeftButton)
    assert station.selected.supervisor.queue == (GoTo(9), GoTo(5))
    localise(topo.nodes[0].pose)
    station.tick()
    assert station.selected.supervisor.current_task == GoTo(9)
    assert "Human-Robot" in panel.current_label.text()
    QTest.mouseClick(panel.cancel_button, Qt.MouseButton.LeftButton)
    station.tick()
    assert station.selected.supervisor.current_task == GoTo(5)


def test_config_apply_and_settings_round_trip(
    qtbot, window, station, settings, topo, clock, tmp_path
):
    """Config and permissions are kept in the station file (their one owner), not in QSettings."""
    store = StationSettingsStore(tmp_path / "station.yaml")
    station.settings = store
    panel = window.config_panel
    panel.spins["latency_ceiling"].setValue(0.8)
    panel.spins["approach_tolerance"].setValue(1.2)
    QTest.mouseClick(panel.apply_button, Qt.MouseButton.LeftButton)
    assert station.arbiter.watchdog.ceiling_s == pytest.approx(0.8)
    assert station.selected.supervisor.config.approach_tolerance == pytest.approx(1.2)
    window.tablet_panel.permission_boxes["tours"].setChecked(False)
    assert not station.tablet_policy.permissions.tours
    saved = yaml.safe_load(store.path.read_text(encoding="utf-8"))
    assert saved["config"]["latency_ceiling"] == pytest.approx(0.8)
    assert saved["tablet"]["tours"] is False
    window.close()
    settings.sync()
    assert settings.value("window/geometry") is not None
    assert [k for k in settings.allKeys() if not k.startswith(("window/", "fleet/"))] == []
    # The next start (a fresh controller and window) reads them back from the file.
    fresh = StationController(
        topo, None, topo_path=TOPO_PATH, clock=clock, tablet_port=0, settings=store
    )
    w2 = MainWindow(fresh, settings)
    qtbot.addWidget(w2)
    assert fresh.config.latency_ceiling == pytest.approx(0.8)
    assert fresh.config.approach_tolerance == pytest.approx(1.2)
    assert fresh.arbiter.watchdog.ceiling_s == pytest.approx(0.8)
    assert not fresh.tablet_policy.permissions.tours
    assert w2.config_panel.spins["latency_ceiling"].value() == pytest.approx(0.8)


def test_state_panel_and_robots_panel_show_the_robot(qtbot, window, station, robot, localise):
    localise(Pose2D(1.0, 2.0, math.pi / 2))
    station.poll_link()
    labels = window.state_panel.labels
    assert "x 1.00 m" in labels["pose"].text()
    assert "90.0°" in labels["orientation"].text()
    assert labels["localisation"].text().startswith("localised")
    assert window.robots_panel.robot_list.count() == 1
    assert "commanding" in window.robots_panel.robot_list.item(0).text()


def test_close_shuts_the_controller_down(qtbot, window, station):
    window.close()
    with pytest.raises(ConnectionRefusedError):  # the tablet port no longer accepts
        socket.create_connection(("127.0.0.1", station.tablet.port), timeout=2).close()
    assert not station.clock_timer.isActive()


def test_tour_stops_coloured_on_map(qtbot, window, station, robot, localise, topo):
    from interbot_core.supervisor import GuidedTour

    first = topo.tour_nodes()[0]
    localise(first.pose)
    station.submit(GuidedTour())
    station.tick()
    robot_arrives(qtbot, station, robot)  # at the first stop already
    spots = window.map_view.tour_item.data
    brushes = {
        (round(float(s["x"]), 3), round(float(s["y"]), 3)): s["brush"].color().getRgb()[:3]
        for s in spots
    }
    assert brushes[(round(first.pose.x, 3), round(first.pose.y, 3))] == (0, 170, 0)  # visited
    nxt = topo.nodes[station.selected.supervisor.next_tour_stop].pose
    assert brushes[(round(nxt.x, 3), round(nxt.y, 3))] == (220, 0, 0)  # next
    assert window.task_panel.tour_resume_button.isEnabled()


def test_camera_view_shows_jpeg(qtbot, window, station, robot):
    import time

    from PySide6.QtCore import QBuffer, QByteArray, QIODevice
    from PySide6.QtGui import QColor, QImage

    from interbot_core.topics import ImageMsg

    image = QImage(64, 48, QImage.Format.Format_RGB32)
    image.fill(QColor(10, 200, 30))
    data = QByteArray()
    buf = QBuffer(data)
    buf.open(QIODevice.OpenModeFlag.WriteOnly)
    image.save(buf, "JPG")
    stamp = time.monotonic()

    def shown() -> bool:  # a DROP stream: published until it arrives, as a daemon does
        robot.link.publish(Topic.IMAGE, ImageMsg(stamp, 64, 48, bytes(data.data())))
        station.poll_link()
        return not window.camera_view.image.isNull()

    qtbot.waitUntil(shown, timeout=10_000)
    assert window.camera_view.image.size().width() == 64
    assert window.camera_view.pixmap() is not None


def test_diagnostics_histograms_follow_period_stats(qtbot, window, station, clock):
    for _ in range(10):
        clock.advance(0.1)
        station.tick()
    window.diagnostics_panel.redraw()
    _, bars, label = window.diagnostics_panel.plots["clock"]
    heights = bars.opts["height"]
    assert sum(heights) == pytest.approx(100.0)  # percent of the periods
    assert "n=9" in label.text() and "mean 100.0 ms" in label.text()


def test_assisted_driving_checkbox_switches_the_robot_and_shows_the_monitor(
    qtbot, linked, window, robot
):
    from interbot_core.topics import SafetyMsg, Topic

    panel = window.teleop_panel
    assert not panel.assist_check.isChecked()
    panel.assist_check.click()  # the operator ticks "Assisted driving"
    # The station's state (off) went out on connecting; the tick sends "on".
    qtbot.waitUntil(lambda: any(m.enabled for m in robot.of("teleop_assist")), timeout=10_000)
    sent = robot.of("teleop_assist")[-1]
    assert (sent.input, sent.enabled) == ("station_vel", True)
    assert linked.robot_link.assist
    linked.selected.state.apply(Topic.SAFETY, SafetyMsg("stop", "FootprintStop", 0.03, 0.1, 0.0))
    linked.frame_ready.emit()
    assert "STOPPED" in panel.monitor_label.text() and "3 cm" in panel.monitor_label.text()


def test_scan_drawn_as_points_from_the_pose_at_its_time(qtbot, window, station, robot):
    """A scan stamped between two poses is placed from the interpolated pose, laser mount
    included; points, not a polyline."""
    import numpy as np

    from interbot_core.laser_scan import INTERBOT_LASER_MOUNT, LaserScan
    from interbot_core.topics import PoseMsg

    for x, stamp in ((0.0, 10.0), (2.0, 10.2)):  # the pose topic keeps only the newest: wait

        def got(x: float = x, stamp: float = stamp) -> bool:  # DROP: sent until it arrives
            robot.link.publish(Topic.POSE, PoseMsg(x, 0.0, 0.0, stamp=stamp))
            station.poll_link()
            return (
                station.selected.state.pose is not None
                and station.selected.state.pose.stamp == stamp
            )

        qtbot.waitUntil(got, timeout=10_000)
    ranges = np.array([1.0, 1.0], dtype=np.float32)  # straight ahead and 90° left

    def drawn() -> bool:  # a DROP stream: published until it arrives, as a daemon does
        robot.link.publish_scan(LaserScan(10.1, 0.0, math.pi / 2, 0.1, 30.0, ranges))
        station.poll_link()
        window.map_view.redraw()
        return len(window.map_view.scan_item) == 2

    qtbot.waitUntil(drawn, timeout=10_000)
    xs, ys = window.map_view.scan_item.getData()
    laser_x = 1.0 + INTERBOT_LASER_MOUNT.x  # robot at x = 1.0 at t = 10.1
    assert sorted(zip(np.round(xs, 3), np.round(ys, 3), strict=False)) == sorted(
        [(round(laser_x + 1.0, 3), 0.0), (round(laser_x, 3), 1.0)]
    )


def test_route_drawn_along_the_robots_planned_path(qtbot, window, station, robot, localise):
    """The route line is the path the robot published, not straight lines between goals."""
    import numpy as np

    from interbot_core.supervisor import GoTo
    from interbot_core.topics import PlanMsg

    localise(Pose2D(-29.5, 3.7, 0.0))
    station.submit(GoTo(5))
    station.tick()
    route = station.selected.route
    assert route is not None
    bend = ((-29.5, 3.7), (-25.0, 3.7), (-25.0, -1.0), (-20.0, -1.0))
    robot.link.publish(Topic.PLAN, PlanMsg(route.route_id, bend))

    def drawn() -> bool:
        station.poll_link()
        window.map_view._invalidate()
        window.map_view.redraw()
        return len(window.map_view.route_item.getData()[0]) == len(bend) + 1

    qtbot.waitUntil(drawn, timeout=10_000)
    xs, ys = window.map_view.route_item.getData()
    assert np.allclose(np.column_stack((xs, ys))[1:], bend)
    robot.link.publish(Topic.PLAN, PlanMsg(route.route_id + 1, bend))  # another route's plan

    def cleared() -> bool:
        station.poll_link()
        window.map_view._invalidate()
        window.map_view.redraw()
        return len(window.map_view.route_item.getData()[0]) == 0

    qtbot.waitUntil(cleared, timeout=10_000)
    assert len(window.map_view.goal_item.data) == 1  # the current goal is still marked


def test_emergency_stop_is_large_red_and_cannot_be_hidden(qtbot, window, station):
    button = window.estop_button
    assert button.isVisible() or not window.isVisible()
    assert button.minimumHeight() >= 44 and button.minimumWidth() >= 200
    assert "#d00000" in button.styleSheet()
    from PySide6.QtWidgets import QToolBar

    bar = window.findChild(QToolBar, "main_toolbar")
    assert bar is not None and not bar.isMovable() and not bar.toggleViewAction().isVisible()
    QTest.mouseClick(button, Qt.MouseButton.LeftButton)
    assert station.estop_latched


def test_unset_pose_shows_dashes(qtbot, window, station, robot, localise):
    localise(Pose2D(0.0, 0.0, 0.0), state="unset")
    station.poll_link()
    window.state_panel.refresh()
    assert window.state_panel.labels["pose"].text() == "—"
    assert window.state_panel.labels["orientation"].text() == "—"


def test_camera_pane_takes_the_image_shape(qtbot, window, station):
    window.resize(1600, 1000)
    window.show()
    qtbot.waitExposed(window)
    total = sum(window._left.sizes())
    for aspect in (16 / 9, 4.0):  # capped at 45 % of the height; then the exact shape
        window.fit_camera(aspect)
        want = min(window._left.width() / aspect, 0.45 * total)
        assert abs(window.camera_view.height() - want) <= 2


def test_alerts_from_the_robot_reach_the_list_and_the_badge(qtbot, window, station, robot):
    """A collision the robot reports is an alert: listed, counted on the toolbar, acknowledged."""
    from interbot_core.topics import Status

    assert window.alerts_action.text() == "No alerts"
    robot.link.publish(
        Topic.STATUS, Status("error", "collision: motors stalled against an obstacle")
    )

    def listed() -> bool:
        station.poll_link()
        station.tick()
        return window.alerts_panel.table.rowCount() == 1

    qtbot.waitUntil(listed, timeout=10_000)
    assert window.alerts_panel.table.item(0, 2).text() == "collision"
    assert window.alerts_action.text() == "1 alert"
    QTest.mouseClick(window.alerts_badge, Qt.MouseButton.LeftButton)
    assert window.tabs.currentWidget() is window.alerts_panel
    panel = window.alerts_panel
    QTest.mouseClick(panel.ack_button, Qt.MouseButton.LeftButton)  # nothing selected
    assert window.alerts_action.text() == "1 alert"
    panel.table.selectRow(0)
    QTest.mouseClick(panel.ack_button, Qt.MouseButton.LeftButton)
    station.tick()
    assert window.alerts_action.text() == "No alerts"
    assert station.alerts.unacknowledged == []
    QTest.mouseClick(panel.ack_all_button, Qt.MouseButton.LeftButton)  # nothing left: no error
    assert station.alerts.unacknowledged == []
