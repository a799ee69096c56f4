"""The real `interbot-daemon` process on the hardware backend, devices emulated on ptys.

The Hokuyo and RoboteQ emulators run as threads of this process on pseudo-terminals; the
daemon is started with ``--config`` pointing at a robot.yaml whose ports are those ptys, and a
station (`StationLink` on a loopback zenoh session) drives it: teleoperation turns the wheels,
scans and battery arrive at the station, and SIGTERM zeroes the motors and exits 0.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import yaml

from interbot_core.laser_scan import LaserScan
from interbot_core.topics import Battery, StopRelease, Topic, Twist
from interbot_link import StateMessage, StationLink, open_session
from tests.robot_daemon.hardware.emulators.hokuyo_emulator import HokuyoEmulator
from tests.robot_daemon.hardware.emulators.roboteq_emulator import RoboteqEmulator

ROBOT = "hwbot"
pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def emulators(tmp_path: Path) -> Iterator[tuple[HokuyoEmulator, RoboteqEmulator]]:
    hokuyo = HokuyoEmulator(link=tmp_path / "ttyACM0")
    roboteq = RoboteqEmulator(link=tmp_path / "ttyUSB0")
    hokuyo.start()
    roboteq.start()
    try:
        yield hokuyo, roboteq
    finally:
        hokuyo.stop()
        roboteq.stop()


def _robot_yaml(tmp_path: Path, endpoint: str, laser: str, motors: str) -> Path:
    config = {
        "robot_id": ROBOT,
        "backend": "hardware",
        "zenoh": {"listen": [endpoint], "connect": []},
        "hardware": {
            "laser": {"port": laser},
            "motors": {
                "port": motors,
                "wheel_radius": 0.1,
                "track": 0.5,
                "counts_per_rev": 2048,
                "gear_ratio": 20.0,
                "max_rpm": 3000,
                "command": "G",
                # Long enough that a watchdog trip cannot pass for the daemon's own zero.
                "watchdog_ms": 5000,
            },
            "camera": {"enabled": False},
        },
    }
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(config), encoding="utf-8")
    return path


def test_station_drives_emulated_hardware_through_the_daemon(
    tmp_path: Path,
    emulators: tuple[HokuyoEmulator, RoboteqEmulator],
    free_tcp_port: Callable[[], int],
    wait_until: Callable[..., None],
) -> None:
    hokuyo, roboteq = emulators
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    config = _robot_yaml(tmp_path, endpoint, hokuyo.port, roboteq.port)
    cmd = [sys.executable, "-m", "robot_daemon.main", "--config", str(config)]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("NOTIFY_SOCKET", None)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
    seen: dict[Topic, object] = {}
    try:
        with open_session([], [endpoint]) as session:
            station = StationLink(session)
            try:

                def pump() -> None:
                    seen.update(station.poll_state())
                    for event in station.poll_events():
                        if isinstance(event, StateMessage):
                            seen[event.topic] = event.message

                wait_until(lambda: ROBOT in station.robots, 20.0, "the daemon's liveliness token")
                station.select_robot(ROBOT)
                counts0 = roboteq.counts()

                def wheels_turn() -> bool:
                    # As a station does on connecting: release the robot's start latch.
                    station.send(Topic.STOP_RELEASE, StopRelease("test station"))
                    station.send(Topic.STATION_VEL, Twist(0.2, 0.0))
                    left, right = roboteq.applied_rpm
                    return left != 0.0 and right != 0.0

                wait_until(wheels_turn, 10.0, "station_vel to reach the RoboteQ")
                # 0.2 m/s on r = 0.1 m, 20:1 gear: 2 rad/s at the wheel = 382 motor rpm,
                # both channels forward (left_sign = right_sign = 1 in this robot.yaml).
                left, right = roboteq.applied_rpm
                assert abs(left - 382.0) < 20.0 and abs(right - 382.0) < 20.0

                def moved() -> bool:
                    station.send(Topic.STATION_VEL, Twist(0.2, 0.0))
                    c = roboteq.counts()
                    return abs(c[0] - counts0[0]) > 1000 and abs(c[1] - counts0[1]) > 1000

                wait_until(moved, 10.0, "the encoder counts to advance")

                def state_arrived() -> bool:
                    pump()
                    return isinstance(seen.get(Topic.SCAN), LaserScan) and isinstance(
                        seen.get(Topic.BATTERY), Battery
                    )

                wait_until(state_arrived, 10.0, "scan and battery at the station")
                scan = seen[Topic.SCAN]
                battery = seen[Topic.BATTERY]
                assert isinstance(scan, LaserScan) and len(scan.ranges) == 1081
                assert isinstance(battery, Battery) and 20.0 < battery.voltage < 35.0

                station.send(Topic.STATION_VEL, Twist(0.2, 0.0))  # still moving when SIGTERM comes
                assert roboteq.applied_rpm != (0.0, 0.0)
                proc.send_signal(signal.SIGTERM)
                assert proc.wait(15.0) == 0
                assert not roboteq.tripped, "the controller's watchdog, not the daemon, stopped"
                assert roboteq.applied_rpm == (0.0, 0.0)
            finally:
                station.close()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        output = proc.stdout.read().decode() if proc.stdout else ""
        if proc.stdout:
            proc.stdout.close()
    assert "daemon ready" in output and "daemon stopped" in output, output[-2000:]
