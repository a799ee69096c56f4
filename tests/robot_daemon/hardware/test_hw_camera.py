"""The camera driver with fake capture devices (no camera on the test machine)."""

from __future__ import annotations

import threading
from collections.abc import Callable

import cv2
import numpy as np
import pytest

from robot_daemon.hardware.camera import CameraDriver
from robot_daemon.hardware.config import CameraConfig
from robot_daemon.sim.camera_sim import encode_jpeg

Until = Callable[..., bool]


class FakeCapture:
    """A camera delivering 640 x 480 frames every 2 ms, optionally failing after ``frames``."""

    def __init__(self, opened: bool = True, frames: int | None = None) -> None:
        self.opened = opened
        self.remaining = frames
        self.props: dict[int, float] = {}
        self.released = False
        self._pace = threading.Event()

    def isOpened(self) -> bool:
        return self.opened

    def set(self, prop_id: int, value: float) -> bool:
        self.props[prop_id] = value
        return True

    def read(self) -> tuple[bool, np.ndarray | None]:
        self._pace.wait(0.002)  # the device's frame period
        if self.remaining is not None:
            if self.remaining <= 0:
                return False, None
            self.remaining -= 1
        frame = np.zeros((480, 640, 3), np.uint8)
        frame[:, :320] = (0, 0, 255)
        return True, frame

    def release(self) -> None:
        self.released = True


def test_a_camera_frame_is_resized_and_encoded_as_jpeg() -> None:
    frame = np.full((480, 640, 3), 128, np.uint8)
    jpeg = encode_jpeg(frame, 70, (320, 240))
    assert jpeg[:2] == b"\xff\xd8"
    decoded = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert decoded is not None and decoded.shape == (240, 320, 3)


def test_frames_at_configured_size_and_rate(until: Until) -> None:
    fake = FakeCapture()
    config = CameraConfig(device="/dev/video7", width=160, height=120, fps=50.0)
    opened: list[int | str] = []

    def factory(device: int | str) -> FakeCapture:
        opened.append(device)
        return fake

    driver = CameraDriver(config, capture_factory=factory).start()
    try:
        assert until(lambda: driver.latest()[0] >= 3)
        seq, frame = driver.latest()
        assert frame is not None
        stamp, jpeg = frame
        assert stamp > 0
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert image is not None and image.shape == (120, 160, 3)
        assert image[60, 10, 2] > 200 and image[60, 150, 2] < 50  # red left half survives
        assert opened == ["/dev/video7"]
        assert fake.props[cv2.CAP_PROP_FRAME_WIDTH] == 160
        assert fake.props[cv2.CAP_PROP_FPS] == 50.0
        status = driver.status()
        assert status.ok and status.counters["frames"] == pytest.approx(seq, abs=1)
    finally:
        driver.close()
    assert fake.released


def test_rate_limit_skips_frames(until: Until) -> None:
    fake = FakeCapture(frames=200)
    driver = CameraDriver(CameraConfig(fps=20.0), capture_factory=lambda d: fake).start()
    try:
        assert until(lambda: fake.remaining == 0, 5.0)
        encoded = driver.status().counters["frames"]
        assert 2 <= encoded < 60  # 200 frames in >= 0.4 s at 20 Hz: a handful, not 200
    finally:
        driver.close()


def test_missing_camera_is_a_status(until: Until) -> None:
    driver = CameraDriver(
        CameraConfig(device=3, reopen_delay=0.02),
        capture_factory=lambda d: FakeCapture(opened=False),
    ).start()
    try:
        assert until(lambda: driver.status().counters["open_failures"] >= 2)
        status = driver.status()
        assert not status.ok and "not available" in status.message
        assert driver.latest() == (0, None)
    finally:
        driver.close()


def test_camera_that_stops_is_reopened(until: Until) -> None:
    captures = [FakeCapture(frames=3), FakeCapture()]
    driver = CameraDriver(
        CameraConfig(fps=100.0, reopen_delay=0.02), capture_factory=lambda d: captures.pop(0)
    ).start()
    try:
        assert until(lambda: driver.status().counters["reopens"] == 1)
        assert until(lambda: driver.status().ok and driver.latest()[0] >= 4)
        assert driver.status().counters["read_failures"] >= 5
    finally:
        driver.close()


def test_factory_exception_and_disabled_camera(until: Until) -> None:
    def broken(device: int | str) -> FakeCapture:
        raise RuntimeError("no V4L2 backend")

    driver = CameraDriver(CameraConfig(reopen_delay=0.02), capture_factory=broken).start()
    try:
        assert until(lambda: driver.status().counters["open_failures"] >= 1)
        assert not driver.status().ok
    finally:
        driver.close()
    disabled = CameraDriver(CameraConfig(enabled=False)).start()
    assert disabled.status().message == "disabled in robot.yaml"
    disabled.close()
