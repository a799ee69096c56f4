"""Camera render and JPEG encoding."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.sim.camera_sim import CameraConfig, CameraConfigError, CameraSim, encode_jpeg
from robot_daemon.sim.laser_sim import RayCaster
from robot_daemon.sim.world import World


def camera() -> CameraSim:
    cells = np.full((120, 200), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    return CameraSim(RayCaster(World(OccupancyGrid(cells, 0.05, 0.0, 0.0))))


def wall_rows(frame: np.ndarray, col: int) -> int:
    """Number of rows in a column that are wall-grey (B, G, R close to each other, not floor)."""
    px = frame[:, col].astype(int)
    return int(((np.abs(px[:, 0] - px[:, 2]) < 25) & (px[:, 1] > 25)).sum())


def test_frame_shape_and_nearer_wall_is_taller() -> None:
    cam = camera()
    near = cam.render(Pose2D(7.75, 3.0, 0.0))  # camera 2 m from the +x wall
    far = cam.render(Pose2D(1.75, 3.0, 0.0))  # 8 m from it
    assert near.shape == (240, 320, 3) and near.dtype == np.uint8
    assert wall_rows(near, 160) > wall_rows(far, 160)
    f = cam.config.focal_px
    expected = f * 2.5 / (9.95 - 8.0)  # wall height in pixels at 1.95 m
    assert abs(wall_rows(near, 160) - min(expected, 240)) <= 3


def test_person_appears_in_its_colour() -> None:
    cam = camera()
    frame = cam.render(Pose2D(2.0, 3.0, 0.0), np.array([[5.0, 3.0, 0.25]]))
    centre = frame[120, 160].astype(int)
    assert centre[2] > 150 and centre[0] < 80  # the first person colour is red (BGR)
    assert (frame[120, 0].astype(int) != centre).any()


def test_encode_jpeg_round_trip() -> None:
    frame = camera().render(Pose2D(2.0, 3.0, 0.5))
    data = encode_jpeg(frame, 80)
    assert data[:2] == b"\xff\xd8"
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == frame.shape
    assert np.abs(decoded.astype(int) - frame.astype(int)).mean() < 6
    assert len(encode_jpeg(frame, 20)) < len(data)
    with pytest.raises(CameraConfigError, match="quality"):
        encode_jpeg(frame, 0)
    with pytest.raises(CameraConfigError, match="uint8"):
        encode_jpeg(frame.astype(np.float32), 80)


def test_invalid_config() -> None:
    with pytest.raises(CameraConfigError, match="fov"):
        CameraConfig(fov=4.0)
