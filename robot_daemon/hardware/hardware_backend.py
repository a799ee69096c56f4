"""The real robot behind the `RobotBackend` interface: Hokuyo + RoboteQ + USB camera.

Each device has a driver thread that owns its port and does all blocking I/O (reads with
timeouts, handshakes, reconnection waits); the daemon's control loop only takes the newest
results, which the drivers hand over under a lock with a sequence number. So a slow or
unplugged device never stalls the loop, nothing is read twice and no scan is half-used.
(Non-blocking reads polled from the loop were the alternative: they would tie the laser's
40 Hz stream and the 50 Hz encoder polling to the loop's 10 Hz and put reconnection waits in
it.) Stamps come from ``clock`` (default ``time.monotonic``, the daemon's clock on a robot).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from interbot_core.laser_scan import LaserScan
from robot_daemon.backend import BatteryReading, DeviceStatus, OdometryReading
from robot_daemon.hardware.camera import CameraDriver, CaptureFactory
from robot_daemon.hardware.config import HardwareConfig
from robot_daemon.hardware.hokuyo_driver import HokuyoDriver
from robot_daemon.hardware.roboteq_driver import RoboteqDriver

logger = logging.getLogger(__name__)


class HardwareBackend:
    """`RobotBackend` on the three device drivers (started in the constructor)."""

    def __init__(
        self,
        config: HardwareConfig,
        clock: Callable[[], float] = time.monotonic,
        capture_factory: CaptureFactory | None = None,
    ) -> None:
        self.config = config
        self.laser = HokuyoDriver(config.laser, clock)
        self.motors = RoboteqDriver(config.motors, config.battery, clock)
        self.camera = CameraDriver(config.camera, clock, capture_factory)
        self._scan_seq = 0
        self._frame_seq = 0
        self._closed = False
        logger.info(
            "hardware backend: laser %s, motors %s (%s, watchdog %d ms), camera %r",
            config.laser.port,
            config.motors.port,
            config.motors.command,
            config.motors.watchdog_ms,
            config.camera.device,
        )
        self.laser.start()
        self.motors.start()
        self.camera.start()

    def set_cmd_vel(self, linear: float, angular: float, now: float) -> None:
        if not self._closed:
            self.motors.set_cmd_vel(linear, angular)

    def read_odometry(self, now: float) -> OdometryReading | None:
        return self.motors.odometry()

    def read_scan(self, now: float) -> LaserScan | None:
        seq, scan = self.laser.latest()
        if scan is None or seq == self._scan_seq:
            return None
        self._scan_seq = seq
        return scan

    def read_camera_jpeg(self, now: float) -> bytes | None:
        seq, frame = self.camera.latest()
        if frame is None or seq == self._frame_seq:
            return None
        self._frame_seq = seq
        return frame[1]

    def read_battery(self, now: float) -> BatteryReading | None:
        return self.motors.battery()

    def device_status(self) -> list[DeviceStatus]:
        return [self.laser.status(), self.motors.status(), self.camera.status()]

    def close(self) -> None:
        """Zero the motors, stop the laser (QT, RS), release the camera; idempotent."""
        if self._closed:
            return
        self._closed = True
        self.motors.close()
        self.laser.close()
        self.camera.close()
