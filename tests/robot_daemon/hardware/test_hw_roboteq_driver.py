"""The RoboteQ driver against the controller emulator on a pseudo-terminal."""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import serial

from robot_daemon.hardware.config import MotorsConfig
from robot_daemon.hardware.roboteq_driver import RoboteqDriver
from tests.robot_daemon.hardware.emulators.roboteq_emulator import RoboteqEmulator

Until = Callable[..., bool]


def _config(port: str, **changes: object) -> MotorsConfig:
    values: dict[str, object] = {
        "port": port,
        "watchdog_ms": 200,
        "reconnect_delay": 0.05,
        "poll_hz": 100.0,
    }
    values.update(changes)
    return MotorsConfig(**values)  # type: ignore[arg-type]


def commanding(
    driver: RoboteqDriver,
    linear: float,
    angular: float,
    until: Until,
    predicate: Callable[[], bool],
    timeout: float = 10.0,
) -> bool:
    """Command the twist every 20 ms, as the daemon's loop does, until ``predicate`` holds.

    One `set_cmd_vel` is not enough on a loaded machine: the driver drops a twist older than
    the watchdog when its thread wakes (stale), and the controller's watchdog stops the motors
    ``watchdog_ms`` after the last command.
    """
    last = -1.0

    def command_and_check() -> bool:
        nonlocal last
        if time.monotonic() - last >= 0.02:
            driver.set_cmd_vel(linear, angular)
            last = time.monotonic()
        return predicate()

    return until(command_and_check, timeout)


@pytest.fixture
def driver(roboteq: RoboteqEmulator, until: Until) -> Iterator[RoboteqDriver]:
    drv = RoboteqDriver(_config(roboteq.port)).start()
    assert until(lambda: drv.odometry() is not None)
    yield drv
    drv.close()


def test_emulator_watchdog_trap_resumes_previous_speed(
    roboteq: RoboteqEmulator, until: Until
) -> None:
    """The manual's behaviour, with a naive client that does not send zero first."""
    with serial.Serial(roboteq.port, 115200, timeout=0.3) as port:
        port.write(b"^ECHOF 1\r^RWD 100\r!G 1 500\r!G 2 500\r")
        assert until(lambda: roboteq.has_applied(lambda rpm: rpm == (1500.0, 1500.0)))
        assert until(lambda: roboteq.tripped)
        assert roboteq.applied_rpm == (0.0, 0.0)
        port.write(b"!G 1 0\r")  # channel 2 wakes up at its old speed
        assert until(lambda: roboteq.resumed == [(2, 1500.0)])
        assert roboteq.applied_log[-2:] == [(0.0, 0.0), (0.0, 1500.0)]


def test_start_up_sets_echo_off_watchdog_and_zero(
    roboteq: RoboteqEmulator, driver: RoboteqDriver
) -> None:
    assert roboteq.commands[:5] == ["^ECHOF 1", "^RWD 200", "!G 1 0", "!G 2 0", "?C"]
    assert not roboteq.echo and roboteq.watchdog_ms == 200
    assert driver.status().ok


def test_twist_becomes_channel_commands_and_odometry(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    geometry = driver.geometry
    expected_rpm = round(geometry.motor_rpm(0.5) / geometry.max_rpm * 1000) / 1000 * 3000
    expected = (expected_rpm, expected_rpm)
    assert commanding(driver, 0.5, 0.0, until, lambda: roboteq.has_applied(expected.__eq__))
    start = driver.odometry()
    assert start is not None
    # The speed each poll reports, while the robot is kept moving (as the daemon does); its
    # median, because one poll's interval is stamped from the host's side of a round trip
    # that a loaded machine may stretch.
    speeds: list[float] = []
    stamps: list[float] = []

    def moved() -> bool:
        odom = driver.odometry()
        if odom is not None and (not speeds or odom.stamp != stamps[-1]):
            speeds.append(odom.linear)
            stamps.append(odom.stamp)
        return odom is not None and odom.pose.x - start.pose.x > 0.2 and len(speeds) >= 10

    assert commanding(driver, 0.5, 0.0, until, moved)
    odom = driver.odometry()
    assert odom is not None
    assert odom.pose.y == pytest.approx(0.0, abs=1e-9)
    assert statistics.median(speeds) == pytest.approx(
        expected_rpm / geometry.motor_rpm(1.0), rel=0.25
    )
    m = len(roboteq.commands)

    def zero_sent() -> bool:
        bangs = [c for c in roboteq.commands[m:] if c.startswith("!")]
        return bangs[-2:] == ["!G 1 0", "!G 2 0"] and roboteq.applied_rpm == (0.0, 0.0)

    assert commanding(driver, 0.0, 0.0, until, zero_sent)


def test_odometry_matches_counts_for_a_rotation(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    g = driver.geometry
    base = driver.odometry()
    assert base is not None
    n = round(
        math.pi / 2 * g.track / 2 / g.metres_per_count_lr[0]
    )  # a quarter turn of wheel travel
    left, right = roboteq.counts()
    roboteq.set_counts(left - n, right + n)
    assert until(lambda: (o := driver.odometry()) is not None and o.pose.yaw - base.pose.yaw > 1.0)
    odom = driver.odometry()
    assert odom is not None
    assert odom.pose.yaw - base.pose.yaw == pytest.approx(math.pi / 2, abs=1e-3)
    assert math.hypot(odom.pose.x - base.pose.x, odom.pose.y - base.pose.y) < 1e-6


def test_counter_wrap_through_the_controller(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    g = driver.geometry
    roboteq.set_counts(2**31 - 10, 2**31 - 10)
    assert until(lambda: driver.status().counters["odometry"] > 3)
    before = driver.odometry()
    assert before is not None
    n = round(0.25 / g.metres_per_count_lr[0])
    wrapped = (2**31 - 10 + n + 2**31) % 2**32 - 2**31
    roboteq.set_counts(wrapped, wrapped)
    assert until(lambda: (o := driver.odometry()) is not None and o.pose.x - before.pose.x > 0.2)
    odom = driver.odometry()
    assert odom is not None
    assert odom.pose.x - before.pose.x == pytest.approx(0.25, abs=1e-3)


def test_clamped_command_is_counted_and_logged(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until, caplog: pytest.LogCaptureFixture
) -> None:
    assert commanding(
        driver, 20.0, 0.0, until, lambda: roboteq.has_applied((3000.0, 3000.0).__eq__)
    )
    assert driver.status().counters["clamped"] >= 1  # each clamped command is counted
    assert caplog.text.count("exceeds max_rpm") == 1  # logged when clamping starts, once


def test_battery_current_and_voltage(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    assert until(lambda: driver.battery() is not None)
    battery = driver.battery()
    assert battery is not None
    assert battery.voltage == pytest.approx(29.6)
    assert battery.current == pytest.approx(1.6)  # 2 x 0.8 A idle, from ?BA (not a voltage)
    assert 0.3 < battery.state_of_charge < 0.7


def test_fault_flags_make_the_status_not_ok(tmp_path: Path, until: Until) -> None:
    with RoboteqEmulator(link=tmp_path / "tty") as emu:
        emu.set_fault_flags(0b10100)
        drv = RoboteqDriver(_config(emu.port)).start()
        try:
            assert until(lambda: "faults" in drv.status().message)
            status = drv.status()
            assert not status.ok
            assert "undervoltage" in status.message and "emergency stop" in status.message
        finally:
            drv.close()


def test_zero_first_after_a_watchdog_trip(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    assert commanding(driver, 0.5, 0.0, until, lambda: roboteq.has_applied(lambda r: r[0] > 0))
    assert until(lambda: roboteq.tripped)  # the daemon went silent for > 200 ms
    assert roboteq.applied_rpm == (0.0, 0.0)
    n, k = len(roboteq.commands), len(roboteq.applied_log)
    assert commanding(
        driver, 0.1, 0.0, until, lambda: roboteq.has_applied(lambda r: r[0] > 0, since=k)
    )
    bangs = [c for c in roboteq.commands[n:] if c.startswith("!")]
    assert bangs[:2] == ["!G 1 0", "!G 2 0"]
    assert roboteq.resumed == []  # no channel kept its pre-trip speed after a batch
    assert driver.status().counters["zero_first"] >= 2  # at start-up and after the trip


def test_malformed_bytes_do_not_crash(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    roboteq.send_garbage(b"\x00\xff\xfejunk\rC=1:x\r\r\r+\r")
    roboteq.drop_replies(1)
    count = driver.status().counters["odometry"]
    assert until(lambda: driver.status().counters["odometry"] > count + 5)
    status = driver.status()
    assert status.ok
    assert status.counters["malformed"] >= 2
    assert status.counters["timeouts"] >= 1


def test_reconnect_after_unplug_sends_zero_first(
    roboteq: RoboteqEmulator, driver: RoboteqDriver, until: Until
) -> None:
    roboteq.unplug(replug_after=0.2)
    assert until(lambda: driver.status().counters["disconnects"] >= 1)
    assert until(lambda: driver.status().counters["connects"] >= 2)
    assert roboteq.commands.count("^RWD 200") >= 2  # the watchdog is set again
    i = len(roboteq.commands) - 1 - roboteq.commands[::-1].index("^RWD 200")
    assert roboteq.commands[i + 1 : i + 3] == ["!G 1 0", "!G 2 0"]
    assert driver.status().ok


def test_close_stops_the_motors(roboteq: RoboteqEmulator, until: Until) -> None:
    drv = RoboteqDriver(_config(roboteq.port, command="S")).start()
    assert until(lambda: drv.odometry() is not None)
    assert commanding(drv, 0.3, 0.2, until, lambda: roboteq.has_applied(lambda r: r[0] > 0))
    left, right = next(r for r in roboteq.applied_log if r[0] > 0)
    assert right > left  # turning left: right wheel faster
    drv.close()
    assert roboteq.applied_rpm == (0.0, 0.0)
    assert roboteq.commands[-2:] == ["!S 1 0", "!S 2 0"]
    assert drv.status().message == "closed"
