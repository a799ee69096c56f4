"""USB camera (thesis §4.1.4, a Logitech web camera): OpenCV capture to JPEG on a thread.

``cv2.VideoCapture(device)`` with the configured width, height and frame rate requested
(the camera may ignore them: frames of another size are resized). Every frame is read, so the
driver's buffer never holds stale images, but only one per ``1 / fps`` seconds is encoded to
JPEG at ``jpeg_quality``. A camera that is missing or stops delivering frames is a status
(``ok=False`` with the reason) and is reopened every ``reopen_delay`` seconds; it never raises
into the daemon. The capture factory is a parameter so tests can use a fake device.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any, Protocol, cast

import cv2

from robot_daemon.backend import DeviceStatus
from robot_daemon.hardware.config import CameraConfig
from robot_daemon.hardware.driver_thread import DriverThread
from robot_daemon.sim.camera_sim import encode_jpeg

logger = logging.getLogger(__name__)

Clock = Callable[[], float]


class FrameSource(Protocol):
    """The part of ``cv2.VideoCapture`` the driver uses."""

    def isOpened(self) -> bool: ...

    def read(self) -> tuple[bool, Any]: ...

    def set(self, prop_id: int, value: float) -> bool: ...

    def release(self) -> None: ...


CaptureFactory = Callable[[int | str], FrameSource]


class CameraDriver(DriverThread):
    """Newest JPEG frame from a USB camera; see the module docstring."""

    THREAD_NAME = "camera-driver"
    MAX_READ_FAILURES = 5  # in a row, before the camera is reopened

    def __init__(
        self,
        config: CameraConfig,
        clock: Clock = time.monotonic,
        capture_factory: CaptureFactory | None = None,
    ) -> None:
        super().__init__(
            f"camera {config.device!r}", ("frames", "open_failures", "read_failures", "reopens")
        )
        self.config = config
        self.clock = clock
        self.capture_factory: CaptureFactory = capture_factory or cast(
            CaptureFactory, cv2.VideoCapture
        )
        self._latest: tuple[float, bytes] | None = None
        self._seq = 0
        if not config.enabled:
            self._message = "disabled in robot.yaml"

    def start(self) -> CameraDriver:
        return super().start() if self.config.enabled else self

    def latest(self) -> tuple[int, tuple[float, bytes] | None]:
        """(sequence number, (stamp, JPEG)) of the newest encoded frame."""
        with self._lock:
            return self._seq, self._latest

    def status(self) -> DeviceStatus:
        with self._lock:
            return DeviceStatus("camera", self._connected, self._message, dict(self.counters))

    def _run(self) -> None:
        c = self.config
        while not self._stop.is_set():
            try:
                capture = self.capture_factory(c.device)
            except Exception as exc:  # OpenCV backends raise cv2.error and others
                capture = None
                logger.debug("camera %r: %s", c.device, exc)
            if capture is None or not capture.isOpened():
                with self._lock:
                    self.counters["open_failures"] += 1
                    first = self.counters["open_failures"] == 1
                if first:
                    logger.warning(
                        "camera %r not available; retrying every %.0f s", c.device, c.reopen_delay
                    )
                self._set_state(False, f"camera {c.device!r} not available")
                if capture is not None:
                    capture.release()
                self._stop.wait(c.reopen_delay)
                continue
            try:
                self._capture(capture)
            finally:
                capture.release()
            if not self._stop.is_set():
                self._count("reopens")
                self._stop.wait(c.reopen_delay)
        self._set_state(False, "closed")

    def _capture(self, capture: FrameSource) -> None:
        c = self.config
        capture.set(cv2.CAP_PROP_FRAME_WIDTH, c.width)
        capture.set(cv2.CAP_PROP_FRAME_HEIGHT, c.height)
        capture.set(cv2.CAP_PROP_FPS, c.fps)
        capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        self._set_state(True, f"camera {c.device!r} {c.width}x{c.height} at {c.fps:g} Hz")
        logger.info("camera %r opened", c.device)
        period = 1.0 / c.fps
        next_due = self.clock()
        failures = 0
        while not self._stop.is_set():
            ok, frame = capture.read()
            if not ok or frame is None:
                failures += 1
                self._count("read_failures")
                if failures >= self.MAX_READ_FAILURES:
                    self._set_state(
                        False, f"camera {c.device!r} stopped delivering frames; reopening"
                    )
                    logger.warning("camera %r stopped delivering frames; reopening", c.device)
                    return
                self._stop.wait(0.05)
                continue
            failures = 0
            now = self.clock()
            if now < next_due:
                continue
            next_due = next_due + period if next_due + period > now else now + period
            jpeg = encode_jpeg(frame, c.jpeg_quality, (c.width, c.height))
            with self._lock:
                self._latest = (now, jpeg)
                self._seq += 1
                self.counters["frames"] += 1
                self._connected = True
                self._message = f"camera {c.device!r} {c.width}x{c.height} at {c.fps:g} Hz"
