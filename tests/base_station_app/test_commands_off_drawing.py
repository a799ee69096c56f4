"""Issue 14: the tablet's commands are not held up behind drawing.

The station's Qt thread forwards the tablet's speed commands and also draws the map. Drawing is
coalesced to the display rate (`DisplayRate`, unit-tested in interbot_core) and the scan is one
cheap `ScanPointsItem`; a flood of scans must neither delay nor reorder nor drop a command.
These tests assert counts and ordering, never wall time (the speed figures are
``interbot bench --only teleop [--busy-core]``).
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from PySide6.QtCore import QSettings, Qt

from base_station_app.main_window import MainWindow
from base_station_app.qt_scan_points import ScanPointsItem
from interbot_core.display_rate import DisplayRate
from interbot_core.topics import Topic, Twist

pytestmark = pytest.mark.qt_log_ignore("propagateSizeHints")


def test_scan_points_keep_finite_points_and_refuse_mismatched_data(qtbot) -> None:
    item = ScanPointsItem()
    item.setData([0.0, np.nan, 2.0, 3.0], [1.0, 1.0, np.inf, 4.0])
    xs, ys = item.getData()
    assert xs.tolist() == [0.0, 3.0] and ys.tolist() == [1.0, 4.0]
    assert len(item) == 2
    with pytest.raises(ValueError, match="2 x values but 3 y values"):
        item.setData([0.0, 1.0], [0.0, 1.0, 2.0])
    assert len(item) == 2  # a refused update changes nothing
    item.setData([], [])
    assert len(item) == 0 and item.boundingRect().isNull()


def test_scan_points_are_painted(qtbot) -> None:
    import pyqtgraph as pg

    plot = pg.PlotWidget()
    qtbot.addWidget(plot)
    plot.resize(300, 300)
    item = ScanPointsItem((255, 0, 0), size=4.0)
    plot.addItem(item)
    angles = np.linspace(0.0, 2 * np.pi, 400)
    item.setData(np.cos(angles), np.sin(angles))
    plot.setRange(xRange=(-1.5, 1.5), yRange=(-1.5, 1.5), padding=0)
    plot.show()
    qtbot.waitExposed(plot)
    image = plot.grab().toImage()
    red = 0
    for x in range(0, image.width(), 2):
        for y in range(0, image.height(), 2):
            c = image.pixelColor(x, y)
            red += c.red() > 200 and c.green() < 60 and c.blue() < 60
    assert red > 50  # the circle of points is on screen


def test_a_flood_of_scans_neither_delays_nor_drops_nor_reorders_commands(
    qtbot, linked, station, robot, tablet_factory, clock, tmp_path, monkeypatch
) -> None:
    window = MainWindow(station, QSettings(str(tmp_path / "s.ini"), QSettings.Format.IniFormat))
    qtbot.addWidget(window)
    window.resize(1200, 800)
    window.show()
    qtbot.waitExposed(window)
    station.display_rate = DisplayRate(15.0)
    # What the Qt and tablet threads did, in order, each entry with the thread that did it.
    trace: list[tuple[str, object, int]] = []

    def arrived(msg: object) -> None:
        trace.append(("arrived", round(msg.angular, 6), threading.get_ident()))  # type: ignore[attr-defined]

    # The speed path runs in the tablet thread (issue 14): note each arrival there, just
    # before the station's own slot forwards it.
    speed_received, forward = station.tablet.speed_received, station.tablet_teleop.on_speed
    speed_received.disconnect(forward)
    speed_received.connect(arrived, Qt.ConnectionType.DirectConnection)
    speed_received.connect(forward)
    station.frame_ready.connect(
        lambda: trace.append(("frame", station.selected.state.scan, threading.get_ident()))
    )
    real_send = station._send

    def send(topic: Topic, message: object) -> bool:
        if topic is Topic.TABLET_VEL and isinstance(message, Twist) and message.angular:
            trace.append(("sent", round(message.angular, 6), threading.get_ident()))
        return real_send(topic, message)

    monkeypatch.setattr(station, "_send", send)
    robot.publish_pose(0.0, 0.0, 0.0)
    t = tablet_factory()
    qtbot.waitUntil(lambda: station.tablet.is_connected, timeout=3000)

    speeds = [round((-1) ** k * (0.1 + 0.01 * k), 6) for k in range(20)]
    scans = polls = 0
    for angular in speeds:
        for _ in range(5):  # 5 polls of 25 ms, each behind a burst of 20 scans (800 Hz)
            for _ in range(20):
                robot.publish_scan()
                scans += 1
            clock.advance(0.025)
            station._on_frame_timer()
            polls += 1
            qtbot.wait(1)
        arrived = sum(1 for kind, _, _ in trace if kind == "arrived")
        t.send({"speed": {"linear": 0.0, "angular": angular}})
        qtbot.waitUntil(
            lambda n=arrived: sum(1 for kind, _, _ in trace if kind == "arrived") == n + 1,
            timeout=3000,
        )

    # Every command was forwarded, in order, and the robot received them all in that order.
    assert [v for kind, v, _ in trace if kind == "sent"] == speeds
    qtbot.waitUntil(
        lambda: len([v for v in robot.of("tablet_vel") if v.angular]) == 20, timeout=3000
    )
    assert [round(v.angular, 6) for v in robot.of("tablet_vel") if v.angular] == speeds
    # Each was sent the moment it arrived, by the thread it arrived in: that thread did nothing
    # (drew no frame) in between. The Qt thread may draw meanwhile; it cannot hold the command up.
    for i, (kind, value, thread) in enumerate(trace):
        if kind == "arrived":
            next_in_thread = next((k, v) for k, v, th in trace[i + 1 :] if th == thread)
            assert next_in_thread == ("sent", value)
    main_thread = threading.main_thread().ident
    assert all(th == main_thread for kind, _, th in trace if kind == "frame")
    # The display was coalesced: 100 polls at 40 Hz behind 2000 scans gave ~15 Hz of frames.
    frames = [scan for kind, scan, _ in trace if kind == "frame"]
    assert scans == 2000 and polls == 100
    assert 30 <= len(frames) <= 40  # 2.5 s of polls at 15 Hz (+ the first)
    assert station.display_rate.coalesced == polls - station.display_rate.frames
    assert any(scan is not None for scan in frames)  # the scans were drawn, the newest ones
    assert len(window.map_view.scan_item) > 0


def test_between_frames_only_events_are_taken_and_the_state_waits_in_its_ring(
    qtbot, station, robot, clock
) -> None:
    """Polls between two frames leave the scan / pose rings alone; the next frame takes the newest."""
    # The state snapshot the station asked for on selecting the robot is an event (it is taken
    # between frames, as it should): let it arrive before the robot publishes the test's poses.
    qtbot.wait(300)
    station.poll_link()
    frames: list[int] = []
    station.frame_ready.connect(lambda: frames.append(station.selected.state.version))
    station.display_rate = DisplayRate(10.0)
    station._on_frame_timer()  # the first poll draws
    assert len(frames) == 1
    for x in (1.0, 2.0, 3.0):
        robot.publish_pose(x, 0.0, 0.0)
        qtbot.wait(30)  # delivered to the station's ring
        clock.advance(0.025)
        station._on_frame_timer()  # within 100 ms of the frame: no state taken, no frame
    assert len(frames) == 1
    assert station.selected.state.pose is None or station.selected.state.pose.x not in (
        1.0,
        2.0,
        3.0,
    )
    qtbot.wait(200)  # the last pose is surely in the ring
    clock.advance(0.03)  # 105 ms after the first frame
    station._on_frame_timer()
    assert len(frames) == 2
    assert (
        station.selected.state.pose is not None and station.selected.state.pose.x == 3.0
    )  # only the newest
