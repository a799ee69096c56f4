"""Assisted teleoperation: it slides through a doorway that a plain scaler (Nav2's
AssistedTeleop: project, then only scale) stops at, never touches a wall, and stops head-on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.safety.arc_geometry import distance_to_polygon
from robot_daemon.safety.assisted_teleop import AssistConfig, AssistedTeleop

FOOTPRINT = np.array(AssistConfig().footprint)
DOOR_X = 1.5  # [m] the wall's near face, 10 cm thick
DOOR_HALF = 0.45  # [m] a 0.90 m door


def door_wall() -> np.ndarray:
    """World points of a wall across x = 1.5 .. 1.6 with a 0.9 m door at y = 0, every 1 cm."""
    pts = []
    for y0, y1 in ((-3.0, -DOOR_HALF), (DOOR_HALF, 3.0)):
        y = np.arange(y0, y1 + 1e-9, 0.01)
        for x in (DOOR_X, DOOR_X + 0.1):
            pts.append(np.column_stack((np.full_like(y, x), y)))
        for yy in (y0, y1):
            x = np.arange(DOOR_X, DOOR_X + 0.1, 0.01)
            pts.append(np.column_stack((x, np.full_like(x, yy))))
    return np.vstack(pts)


def side_wall(y: float) -> np.ndarray:
    x = np.arange(-2.0, 8.0, 0.01)
    return np.column_stack((x, np.full_like(x, y)))


def drive(
    assist: AssistedTeleop,
    world: np.ndarray,
    start: Pose2D,
    intent: tuple[float, float],
    seconds: float,
) -> tuple[Pose2D, float]:
    """Kinematic robot pushed with a constant ``intent`` for ``seconds`` at 10 Hz; returns the end
    pose and the smallest footprint clearance seen (all returns visible: no occlusion)."""
    pose, dt, clearance = start, 0.1, math.inf
    for _ in range(round(seconds / dt)):
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        dx, dy = world[:, 0] - pose.x, world[:, 1] - pose.y
        px, py = c * dx + s * dy, -s * dx + c * dy
        near = np.hypot(px, py) < 6.0
        result = assist.assist(*intent, px[near], py[near])
        v, w = result.linear, result.angular
        for _ in range(10):  # exact arc integration in 1 cm steps
            h = dt / 10
            pose = Pose2D(
                pose.x + v * h * math.cos(pose.yaw + w * h / 2),
                pose.y + v * h * math.sin(pose.yaw + w * h / 2),
                pose.yaw + w * h,
            )
            c, s = math.cos(pose.yaw), math.sin(pose.yaw)
            dx, dy = world[:, 0] - pose.x, world[:, 1] - pose.y
            d = distance_to_polygon(c * dx + s * dy, -s * dx + c * dy, FOOTPRINT)
            clearance = min(clearance, float(d.min()))
    return pose, clearance


@pytest.fixture(scope="module")
def wall() -> np.ndarray:
    return door_wall()


def test_assisted_teleop_slides_through_a_doorway_a_plain_scaler_blocks(wall: np.ndarray) -> None:
    start = Pose2D(0.0, 0.22, 0.0)  # 22 cm off the door's axis, pushing straight ahead
    plain = AssistedTeleop(AssistConfig(curvature_span=0.0, curvature_samples=1))
    end_plain, clear_plain = drive(plain, wall, start, (0.4, 0.0), 12.0)
    assert end_plain.x < DOOR_X - 0.3  # stuck in front of the door frame
    assert clear_plain > 0.0
    assisted = AssistedTeleop()
    end, clearance = drive(assisted, wall, start, (0.4, 0.0), 12.0)
    assert end.x > DOOR_X + 0.8  # through the door and beyond
    assert clearance > 0.02  # never touched the frame


def test_assisted_teleop_slides_along_a_wall_at_a_shallow_angle() -> None:
    world = side_wall(1.0)
    start = Pose2D(0.0, 0.0, math.radians(20))  # pushing 20 degrees into a wall 1 m to the left
    end, clearance = drive(AssistedTeleop(), world, start, (0.5, 0.0), 8.0)
    assert clearance > 0.02
    assert end.x > 2.5  # kept going along the wall (3.2 m of progress at full speed)


def test_assisted_teleop_stops_head_on_and_turns_on_the_spot_when_free() -> None:
    world = np.column_stack((np.full(400, 0.6), np.linspace(-2, 2, 400)))
    assist = AssistedTeleop()
    end, clearance = drive(assist, world, Pose2D(0.0, 0.0, 0.0), (0.5, 0.0), 5.0)
    assert clearance > 0.02 and end.x < 0.3
    assert abs(end.y) < 0.1  # did not veer away along the wall: head-on means stop
    free = assist.assist(0.0, 1.0, np.array([5.0]), np.array([0.0]))
    assert (free.linear, free.angular, free.mode) == (0.0, 1.0, "free")
