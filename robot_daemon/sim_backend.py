"""The simulator behind the `RobotBackend` interface (the daemon's default backend).

`advance(now)` steps the simulated robot up to the daemon's time ``now``; reads then return
what the simulated devices would have produced: odometry at every step, a laser scan (the
UTM-30LX scans at 40 Hz; ray casting costs about a millisecond, so the backend casts only at
``scan_rate_hz``, the rate its consumers use), a JPEG camera frame at ``camera_rate_hz`` (0 turns
the camera off for headless runs), and the BMS. The simulator's true pose never leaves this module
(metrics read it from `Simulator.true_pose`).
"""

from __future__ import annotations

import math

from interbot_core.laser_scan import LaserScan
from robot_daemon.backend import BatteryReading, DeviceStatus, OdometryReading
from robot_daemon.sim.camera_sim import encode_jpeg
from robot_daemon.sim.simulator import Simulator

JPEG_QUALITY = 70  # as the hardware camera's default (robot.yaml hardware.camera.jpeg_quality)


def _next_deadline(previous: float, period: float, now: float) -> float:
    """The next deadline after ``now`` on the grid ``previous + k * period``."""
    if math.isinf(period):
        return math.inf
    return previous + period * max(1, math.floor((now - previous) / period + 1e-9) + 1)


class SimBackend:
    """`RobotBackend` on a `Simulator`, on simulated time."""

    def __init__(
        self,
        simulator: Simulator,
        *,
        scan_rate_hz: float = 40.0,
        camera_rate_hz: float = 5.0,
    ) -> None:
        if not 0 < scan_rate_hz <= 40.0:
            raise ValueError(f"scan_rate_hz must be in (0, 40], got {scan_rate_hz}")
        if not 0 <= camera_rate_hz <= 30.0:
            raise ValueError(f"camera_rate_hz must be in [0, 30], got {camera_rate_hz}")
        self.sim = simulator
        self._scan_period = 1.0 / scan_rate_hz
        self._camera_period = 1.0 / camera_rate_hz if camera_rate_hz > 0 else math.inf
        self._next_scan = 0.0
        self._next_frame = 0.0
        self._scan_reads = 0

    # -- time --------------------------------------------------------------------------------

    def advance(self, now: float) -> None:
        """Step the simulation forward to ``now`` [s] (never backwards)."""
        dt = now - self.sim.time
        if dt > 0:
            self.sim.step(dt)

    # -- RobotBackend --------------------------------------------------------------------------

    def set_cmd_vel(self, linear: float, angular: float, now: float) -> None:
        self.sim.set_cmd_vel(linear, angular)

    def read_odometry(self, now: float) -> OdometryReading:
        return self.sim.odometry()

    def read_scan(self, now: float) -> LaserScan | None:
        if not self.sim.scan_due() or self.sim.time + 1e-9 < self._next_scan:
            return None
        self._next_scan = _next_deadline(self._next_scan, self._scan_period, self.sim.time)
        self._scan_reads += 1
        return self.sim.scan()

    def read_camera_jpeg(self, now: float) -> bytes | None:
        if not self.sim.camera_due() or self.sim.time + 1e-9 < self._next_frame:
            return None
        self._next_frame = _next_deadline(self._next_frame, self._camera_period, self.sim.time)
        return encode_jpeg(self.sim.camera_frame(), JPEG_QUALITY)

    def read_battery(self, now: float) -> BatteryReading:
        state = self.sim.battery()
        return BatteryReading(state.stamp, state.voltage, state.current, state.soc)

    def device_status(self) -> list[DeviceStatus]:
        return [
            DeviceStatus("laser", True, "simulated UTM-30LX", {"scans": self._scan_reads}),
            # The simulated robot's contact sensor (a bumper, or the motors' stall current):
            # how often the footprint touched a wall, an obstacle or a person.
            DeviceStatus(
                "motors",
                True,
                "simulated differential drive",
                {"contacts": self.sim.collisions},
            ),
            DeviceStatus("camera", True, "simulated camera"),
        ]

    def close(self) -> None:
        self.sim.set_cmd_vel(0.0, 0.0)
