"""Differential-drive kinematics, limits and footprint geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from robot_daemon.sim.diff_drive import (
    DiffDrive,
    DiffDriveConfig,
    DiffDriveConfigError,
    RobotFootprint,
    body_velocity,
    integrate_arc,
    to_world,
    wheel_speeds,
)


def test_straight_line_moves_along_heading() -> None:
    pose = Pose2D(1.0, 2.0, math.radians(30))
    end = integrate_arc(pose, 0.5, 0.0, 4.0)
    assert end.x == pytest.approx(1.0 + 2.0 * math.cos(math.radians(30)))
    assert end.y == pytest.approx(2.0 + 2.0 * math.sin(math.radians(30)))
    assert end.yaw == pytest.approx(pose.yaw)


def test_pure_rotation_stays_in_place() -> None:
    end = integrate_arc(Pose2D(3.0, -1.0, 0.0), 0.0, 0.6, 2 * math.pi / 0.6 / 4)
    assert (end.x, end.y) == pytest.approx((3.0, -1.0))
    assert end.yaw == pytest.approx(math.pi / 2)


@settings(max_examples=150, deadline=None)
@given(
    v=st.floats(-1.0, 1.0),
    w=st.floats(-2.0, 2.0).filter(lambda w: abs(w) > 1e-3),
    yaw=st.floats(-3.1, 3.1),
    dt=st.floats(0.001, 3.0),
)
def test_arc_matches_closed_form(v: float, w: float, yaw: float, dt: float) -> None:
    end = integrate_arc(Pose2D(0.0, 0.0, yaw), v, w, dt)
    radius = v / w
    assert end.x == pytest.approx(radius * (math.sin(yaw + w * dt) - math.sin(yaw)), abs=1e-9)
    assert end.y == pytest.approx(-radius * (math.cos(yaw + w * dt) - math.cos(yaw)), abs=1e-9)
    assert math.cos(end.yaw - (yaw + w * dt)) == pytest.approx(1.0)


def test_many_small_arcs_equal_one_big_arc() -> None:
    pose = Pose2D(0.0, 0.0, 0.3)
    for _ in range(1000):
        pose = integrate_arc(pose, 0.4, 0.7, 0.005)
    once = integrate_arc(Pose2D(0.0, 0.0, 0.3), 0.4, 0.7, 5.0)
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((once.x, once.y, once.yaw), abs=1e-9)


@given(v=st.floats(-2, 2), w=st.floats(-3, 3), b=st.floats(0.2, 1.0))
def test_wheel_speeds_round_trip(v: float, w: float, b: float) -> None:
    left, right = wheel_speeds(v, w, b)
    assert body_velocity(left, right, b) == pytest.approx((v, w), abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(commands=st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), min_size=1, max_size=30))
def test_limits_are_respected(commands: list[tuple[float, float]]) -> None:
    cfg = DiffDriveConfig()
    drive = DiffDrive(cfg)
    dt = 0.01
    for v_cmd, w_cmd in commands:
        drive.command(v_cmd, w_cmd)
        for _ in range(20):
            v0, w0 = drive.velocity
            drive.advance(dt)
            v1, w1 = drive.velocity
            assert abs(v1) <= cfg.max_linear + 1e-12
            assert abs(w1) <= cfg.max_angular + 1e-12
            assert abs(v1 - v0) <= cfg.max_linear_accel * dt + 1e-12
            assert abs(w1 - w0) <= cfg.max_angular_accel * dt + 1e-12


def test_drive_reaches_clamped_target_and_defaults() -> None:
    drive = DiffDrive()
    assert drive.config.max_linear == 0.8 and drive.config.max_angular == 1.5
    assert drive.config.max_linear_accel == 0.6 and drive.config.max_angular_accel == 2.0
    drive.command(3.0, -9.0)
    assert drive.target == (0.8, -1.5)
    for _ in range(200):
        drive.advance(0.01)
    assert drive.velocity == pytest.approx((0.8, -1.5))
    drive.command(float("nan"), 1.0)
    assert drive.target == (0.0, 1.0)


def test_invalid_config_names_field() -> None:
    with pytest.raises(DiffDriveConfigError, match="max_linear"):
        DiffDriveConfig(max_linear=0.0)
    with pytest.raises(DiffDriveConfigError, match="width"):
        RobotFootprint(width=-1.0)


def test_footprint_polygon_and_distance() -> None:
    fp = RobotFootprint()
    assert (fp.length, fp.width) == (0.60, 0.55)
    corners = to_world(Pose2D(1.0, 1.0, math.pi / 2), fp.corners_local())
    assert corners.min(axis=0) == pytest.approx([1.0 - 0.275, 1.0 - 0.30])
    assert corners.max(axis=0) == pytest.approx([1.0 + 0.275, 1.0 + 0.30])
    d = fp.distance_to_points(Pose2D(0, 0, 0), [(1.0, 0.0), (0.0, 0.0), (0.3, 0.275 + 0.1)])
    assert d == pytest.approx([0.7, 0.0, 0.1])
    assert fp.distance_to_point(Pose2D(0, 0, 0), 1.0, 0.0) == pytest.approx(0.7)
    outline = to_world(Pose2D(0, 0, 0), fp.outline_local(0.02))
    steps = np.hypot(*np.diff(np.vstack((outline, outline[:1])), axis=0).T)
    assert steps.max() <= 0.02 + 1e-12
    assert fp.distance_to_points(Pose2D(0, 0, 0), outline) == pytest.approx(0.0, abs=1e-12)


def test_footprint_offset_moves_rectangle() -> None:
    fp = RobotFootprint(offset_x=0.1)
    corners = to_world(Pose2D(0, 0, 0), fp.corners_local())
    assert corners[:, 0].max() == pytest.approx(0.4)
    assert corners[:, 0].min() == pytest.approx(-0.2)
    assert fp.circumscribed_radius == pytest.approx(math.hypot(0.4, 0.275))
