"""Simulated Logitech web camera: a ray-cast pseudo-3D view (thesis §4.1.4), ~10 Hz, JPEG.

The operator's camera stream is for visual context only (teleoperation), so a "2.5-D" raycaster
render in the style of Wolfenstein 3D is enough: one ray per image column over the horizontal
field of view (default 60 degrees), cast with the laser's ``RayCaster`` against walls and people.
With a pinhole of focal length ``f = (W / 2) / tan(fov / 2)`` and the perpendicular depth
``z = r cos(a)`` of a hit at range r and column angle a, an object spanning heights
``[0, h]`` above the floor occupies rows

    top = c_y - f (h - h_cam) / z,    bottom = c_y + f h_cam / z.

Walls (2.5 m) are grey shaded by distance, people (1.7 m) are coloured columns in front of them,
above the horizon is ceiling and below it floor. Output is BGR uint8, 240 x 320 by default.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import cv2
import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from robot_daemon.sim.laser_sim import RayCaster

FloatArray = npt.NDArray[np.float64]
ImageU8 = npt.NDArray[np.uint8]

_PERSON_COLOURS = np.array(
    [[40, 40, 200], [200, 80, 40], [40, 160, 40], [0, 140, 230], [160, 40, 160], [160, 160, 0]],
    dtype=np.float64,
)  # BGR


class CameraConfigError(ValueError):
    """A camera parameter is out of range; the message names the field."""


Pixels = Annotated[int, Meta(ge=16, le=4096)]
FieldOfView = Annotated[float, Meta(gt=0.1, lt=math.pi - 0.1, extra={"unit": "rad"})]


class CameraConfig(schema.Declared, frozen=True):
    """Image size, optics and mounting of the simulated camera."""

    ROOT: ClassVar[str] = "CameraConfig"
    ERROR: ClassVar[type[Exception]] = CameraConfigError
    width: Pixels = 320
    height: Pixels = 240
    fov: FieldOfView = math.radians(60.0)  # horizontal
    frame_period: Annotated[float, Meta(gt=0.0, le=schema.FINITE)] = 0.1  # [s] ~10 Hz
    mount_x: float = 0.25  # [m] ahead of base_link
    mount_height: float = 1.1  # [m] above the floor
    wall_height: float = 2.5  # [m]
    person_height: float = 1.7  # [m]
    max_range: float = 30.0  # [m]

    def check(self) -> None:
        if not 0 < self.mount_height < self.wall_height:
            raise CameraConfigError("CameraConfig.mount_height must be in (0, wall_height) m")

    @property
    def focal_px(self) -> float:
        """Focal length [px]."""
        return (self.width / 2) / math.tan(self.fov / 2)

    def column_angles(self) -> FloatArray:
        """Angle of each column's ray in the camera frame [rad], left (positive) to right."""
        x = np.arange(self.width, dtype=np.float64) + 0.5 - self.width / 2
        result: FloatArray = np.arctan2(-x, self.focal_px)
        return result


class CameraSim:
    """Renders camera frames from the true robot pose (map frame) and people circles."""

    def __init__(self, caster: RayCaster, config: CameraConfig | None = None) -> None:
        self.config = config or CameraConfig()
        self.caster = caster
        c = self.config
        self._angles = c.column_angles()
        self._cos = np.cos(self._angles)
        self._rows = np.arange(c.height, dtype=np.float64)[:, None]
        horizon = c.height / 2
        ramp = np.abs(self._rows - horizon) / horizon  # 0 at the horizon, 1 at the edges
        ceiling = np.array([200.0, 190.0, 180.0]) - 60 * (1 - ramp)
        floor = np.array([90.0, 110.0, 120.0]) + 60 * ramp
        background = np.where(self._rows < horizon, ceiling, floor)  # (H, 3)
        self._background = np.repeat(background[:, None, :], c.width, axis=1)

    def _rows_of(self, depth: FloatArray, top_height: float) -> tuple[FloatArray, FloatArray]:
        c = self.config
        f, cy = c.focal_px, c.height / 2
        z = np.maximum(depth, 1e-3)
        return cy - f * (top_height - c.mount_height) / z, cy + f * c.mount_height / z

    def render(self, robot_pose: Pose2D, circles: FloatArray | None = None) -> ImageU8:
        """A BGR uint8 frame (height x width x 3) seen from a robot at ``robot_pose``."""
        c = self.config
        cam = robot_pose.compose(Pose2D(c.mount_x, 0.0, 0.0))
        angles = self._angles + cam.yaw
        walls = self.caster.cast_walls(cam.x, cam.y, angles, c.max_range)
        image = self._background.copy()
        wall_depth = walls * self._cos
        top, bottom = self._rows_of(wall_depth, c.wall_height)
        shade = np.clip(1.0 / (1.0 + 0.12 * wall_depth), 0.15, 1.0)[:, None]
        wall_colour = np.array([215.0, 225.0, 230.0]) * shade  # (W, 3), inf -> 0.15 shade
        mask = np.isfinite(walls)[None, :] & (self._rows >= top) & (self._rows < bottom)
        image = np.where(mask[:, :, None], wall_colour[None, :, :], image)
        if circles is not None and circles.size:
            ranges, which = self.caster.cast_circles(cam.x, cam.y, angles, circles)
            seen = (which >= 0) & (ranges < walls)
            if seen.any():
                depth = ranges * self._cos
                ptop, pbottom = self._rows_of(depth, c.person_height)
                colour = _PERSON_COLOURS[np.maximum(which, 0) % len(_PERSON_COLOURS)]
                colour = colour * np.clip(1.0 / (1.0 + 0.08 * depth), 0.3, 1.0)[:, None]
                pmask = seen[None, :] & (self._rows >= ptop) & (self._rows < pbottom)
                image = np.where(pmask[:, :, None], colour[None, :, :], image)
        return np.ascontiguousarray(image, dtype=np.uint8)


class JpegEncodeError(RuntimeError):
    """OpenCV could not encode a frame."""


def encode_jpeg(frame: np.ndarray, quality: int = 80, size: tuple[int, int] | None = None) -> bytes:
    """JPEG bytes of a BGR uint8 frame (simulated or a real camera's), resized to ``size``
    (width, height) when given and different; ``quality`` in [1, 100]."""
    if not 1 <= quality <= 100:
        raise CameraConfigError(f"JPEG quality must be in [1, 100], got {quality}")
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
        raise CameraConfigError(
            f"expected an HxWx3 uint8 BGR frame, got {frame.dtype} {frame.shape}"
        )
    if size is not None and (frame.shape[1], frame.shape[0]) != size:
        frame = cv2.resize(frame, size, interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise JpegEncodeError(f"cv2.imencode failed for a {frame.shape} frame")
    return bytes(buf.tobytes())
