"""HardwareBackend on the two emulators and a fake camera: the RobotBackend contract."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import numpy as np

from robot_daemon.backend import RobotBackend
from robot_daemon.hardware.config import HardwareConfig
from robot_daemon.hardware.hardware_backend import HardwareBackend
from tests.robot_daemon.hardware.emulators.hokuyo_emulator import HokuyoEmulator
from tests.robot_daemon.hardware.emulators.roboteq_emulator import RoboteqEmulator

Until = Callable[..., bool]


class _Camera:
    def __init__(self) -> None:
        self._pace = threading.Event()

    def isOpened(self) -> bool:
        return True

    def set(self, prop_id: int, value: float) -> bool:
        return True

    def read(self) -> tuple[bool, np.ndarray]:
        self._pace.wait(0.005)
        return True, np.zeros((240, 320, 3), np.uint8)

    def release(self) -> None:
        pass


def test_backend_contract(hokuyo: HokuyoEmulator, roboteq: RoboteqEmulator, until: Until) -> None:
    config = HardwareConfig.from_mapping(
        {
            "laser": {"port": hokuyo.port, "stall_timeout": 0.2},
            "motors": {"port": roboteq.port, "watchdog_ms": 300, "poll_hz": 100},
            "camera": {"fps": 20},
        }
    )
    backend = HardwareBackend(config, capture_factory=lambda device: _Camera())
    robot: RobotBackend = backend  # structural check of the protocol
    try:
        assert until(lambda: all(s.ok for s in robot.device_status()), 3.0)
        assert [s.name for s in robot.device_status()] == ["laser", "motors", "camera"]
        now = time.monotonic()
        assert until(lambda: robot.read_scan(now) is not None)
        assert until(lambda: robot.read_camera_jpeg(now) is not None)
        assert until(lambda: robot.read_battery(now) is not None)
        robot.set_cmd_vel(0.4, 0.0, now)
        assert until(lambda: roboteq.applied_rpm[0] > 0)
        assert until(lambda: (o := robot.read_odometry(now)) is not None and o.pose.x > 0.02)
        odom = robot.read_odometry(now)
        assert odom is not None and odom.linear > 0.1
        assert abs(odom.stamp - time.monotonic()) < 1.0  # stamped on the daemon's clock
    finally:
        robot.close()
    assert roboteq.applied_rpm == (0.0, 0.0)
    assert hokuyo.commands[-2:] == ["QT", "RS"]
    robot.close()  # idempotent
    robot.set_cmd_vel(1.0, 0.0, 0.0)  # ignored after close
    assert roboteq.applied_rpm == (0.0, 0.0)


def test_each_scan_and_frame_is_returned_once() -> None:
    config = HardwareConfig.from_mapping(
        {
            "laser": {"port": "/nonexistent/laser", "reconnect_delay": 0.05},
            "motors": {"port": "/nonexistent/motors", "reconnect_delay": 0.05},
            "camera": {"enabled": False},
        }
    )
    backend = HardwareBackend(config)
    try:
        assert backend.read_scan(0.0) is None
        assert backend.read_odometry(0.0) is None and backend.read_battery(0.0) is None
        status = {s.name: s for s in backend.device_status()}
        assert not status["laser"].ok and not status["motors"].ok and not status["camera"].ok
        scan_a, scan_b = object(), object()
        latest = {"value": (1, scan_a)}
        backend.laser.latest = lambda: latest["value"]  # type: ignore[method-assign,assignment,return-value]
        assert backend.read_scan(0.0) is scan_a
        assert backend.read_scan(0.0) is None
        latest["value"] = (2, scan_b)
        assert backend.read_scan(0.0) is scan_b
        backend.camera.latest = lambda: (7, (0.0, b"jpeg"))  # type: ignore[method-assign]
        assert backend.read_camera_jpeg(0.0) == b"jpeg"
        assert backend.read_camera_jpeg(0.0) is None
    finally:
        backend.close()
