"""Issue 14: the tablet's speed commands travel in the tablet thread, not the Qt thread.

The Qt thread is held busy (the test thread does not run the event loop, as while a frame is
drawn) and the tablet's commands must still reach the robot, every one of them and in order;
the watchdog's zero must still come on time; the e-stop engaged by the Qt thread must win over
a tablet that keeps driving. Observed at the fake robot's link (its own zenoh session), with
no Qt event processed in between; the tests assert what arrives, not how fast.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable

import pytest
from PySide6.QtCore import QThread

from base_station_app.station_config import StationConfig
from interbot_core.topics import Lock, Twist
from interbot_qt.thread_call import ThreadCall
from tests.base_station_app.test_station_tablet import handshake


def busy_wait(done: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    """Wait for ``done()`` WITHOUT running the Qt event loop (the Qt thread is busy)."""
    deadline = time.monotonic() + timeout_s
    while not done():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


def tablet_vels(robot) -> list[tuple[float, float]]:
    return [(v.linear, v.angular) for v in robot.of("tablet_vel")]


def test_the_tablet_server_and_its_speed_path_live_in_their_own_thread(station) -> None:
    thread = station.tablet.thread()
    assert thread is not QThread.currentThread() and thread.isRunning()
    assert station.tablet_teleop.thread() is thread
    assert station.tablet_teleop.watchdog.thread() is thread


def test_commands_reach_the_robot_while_the_qt_thread_is_busy_none_lost_in_order(
    qtbot, linked, station, robot, tablet_factory
) -> None:
    t = handshake(qtbot, tablet_factory)
    speeds = [round((-1) ** k * (0.1 + 0.01 * k), 6) for k in range(20)]
    for k, angular in enumerate(speeds):
        t.send({"speed": {"linear": 0.0, "angular": angular}})
        # No Qt event runs here: only the tablet thread can forward it.
        assert busy_wait(lambda n=k: len(tablet_vels(robot)) == n + 1), f"command {k} not sent"
    assert [a for _, a in tablet_vels(robot)] == speeds


def test_the_watchdog_zero_comes_while_the_qt_thread_is_busy(
    qtbot, linked, station, robot, tablet_factory
) -> None:
    station.set_config(StationConfig(latency_ceiling=0.2))
    t = handshake(qtbot, tablet_factory)
    qtbot.wait(100)  # the new ceiling reaches the tablet thread's timer
    t.send({"speed": {"linear": 0.2, "angular": 0.0}})
    started = time.monotonic()
    # The tablet stalls; the Qt thread is busy throughout.
    assert busy_wait(lambda: len(tablet_vels(robot)) == 2, timeout_s=5.0)
    assert tablet_vels(robot) == [(0.2, 0.0), (0.0, 0.0)]
    assert time.monotonic() - started >= 0.2 - 0.02  # not before the ceiling
    assert not station.arbiter.tablet_forwarding
    qtbot.waitUntil(
        lambda: any("explicit zero sent" in e.text for e in station.selected.state.log),
        timeout=10_000,
    )


def test_a_tablet_that_disconnects_gets_its_zero_while_the_qt_thread_is_busy(
    qtbot, linked, station, robot, tablet_factory
) -> None:
    station.set_config(StationConfig(latency_ceiling=1.0))  # the watchdog alone: 1 s later
    t = handshake(qtbot, tablet_factory)
    qtbot.wait(100)
    t.send({"speed": {"linear": 0.2, "angular": 0.0}})
    assert busy_wait(lambda: tablet_vels(robot) == [(0.2, 0.0)])
    t.close()
    assert busy_wait(lambda: len(tablet_vels(robot)) == 2, timeout_s=3.0)
    assert tablet_vels(robot) == [(0.2, 0.0), (0.0, 0.0)]
    qtbot.waitUntil(lambda: not station.tablet.is_connected, timeout=10_000)
    qtbot.wait(100)
    assert tablet_vels(robot) == [(0.2, 0.0), (0.0, 0.0)]  # one zero, not one per thread
    stops = [e.text for e in station.selected.state.log if "tablet speed stopped" in e.text]
    assert stops == ["tablet speed stopped (tablet disconnected): explicit zero sent"]


def test_the_emergency_stop_wins_over_a_tablet_that_keeps_driving(
    qtbot, linked, station, robot, tablet_factory
) -> None:
    t = handshake(qtbot, tablet_factory)
    sending = threading.Event()
    sending.set()
    k = [0]

    def drive() -> None:  # a tablet at ~200 Hz, each command its own value
        while sending.is_set():
            k[0] += 1
            t.sock.sendall(json.dumps({"speed": {"linear": 0.0, "angular": 0.001 * k[0]}}).encode())
            time.sleep(0.005)

    driver = threading.Thread(target=drive, daemon=True)
    driver.start()
    try:
        assert busy_wait(lambda: len(tablet_vels(robot)) >= 5)
        station.emergency_stop()  # the Qt thread, while commands keep arriving
        assert not station.arbiter.tablet_forwarding
        qtbot.wait(500)  # the tablet keeps driving; the tablet thread keeps reading
        assert not station.arbiter.tablet_forwarding and station.arbiter.tablet_speed is None
    finally:
        sending.clear()
        driver.join(2.0)
    qtbot.wait(200)
    sent = tablet_vels(robot)
    assert sent[-1] == (0.0, 0.0)  # the explicit zero came last: nothing forwarded after it
    assert sent.count((0.0, 0.0)) == 1
    assert any(isinstance(m, Lock) and m.engaged for m in robot.of("stop"))
    errors = [e["message"] for e in t.of("error")]
    assert sum("emergency stop" in m for m in errors) == 1  # told once per stream
    assert all(isinstance(v, Twist) for v in robot.of("tablet_vel"))


def test_a_thread_call_runs_in_the_owner_thread_and_returns_or_raises(qapp) -> None:
    from PySide6.QtCore import QObject

    thread = QThread()
    owner = QObject()
    call = ThreadCall(owner)
    owner.moveToThread(thread)
    thread.start()
    try:
        assert call.run(lambda: QThread.currentThread() is thread)
        with pytest.raises(ZeroDivisionError):
            call.run(lambda: 1 / 0)
    finally:
        thread.quit()
        thread.wait()
    assert call.run(lambda: 42) == 42  # the thread ended: called directly


def test_withdrawing_teleop_permission_wins_over_a_tablet_that_keeps_driving(
    qtbot, linked, station, robot, tablet_factory
) -> None:
    """The permission the tablet thread checks is written under the speed path's lock: once
    `set_permission` returns, nothing more is forwarded, and the zero comes last."""
    t = handshake(qtbot, tablet_factory)
    sending = threading.Event()
    sending.set()
    k = [0]

    def drive() -> None:  # a tablet at ~200 Hz, each command its own value
        while sending.is_set():
            k[0] += 1
            t.sock.sendall(json.dumps({"speed": {"linear": 0.0, "angular": 0.001 * k[0]}}).encode())
            time.sleep(0.005)

    driver = threading.Thread(target=drive, daemon=True)
    driver.start()
    try:
        assert busy_wait(lambda: len(tablet_vels(robot)) >= 5)
        station.set_permission("teleop", False)  # the Qt thread, while commands keep arriving
        assert not station.arbiter.tablet_forwarding
        qtbot.wait(500)
        assert not station.arbiter.tablet_forwarding and station.arbiter.tablet_speed is None
    finally:
        sending.clear()
        driver.join(2.0)
    qtbot.wait(200)
    sent = tablet_vels(robot)
    assert sent[-1] == (0.0, 0.0) and sent.count((0.0, 0.0)) == 1
    errors = [e["message"] for e in t.of("error")]
    assert sum("does not allow teleop" in m for m in errors) == 1  # told once per stream
