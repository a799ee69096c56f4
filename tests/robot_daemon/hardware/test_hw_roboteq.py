"""RoboteQ command formatting, reply parsing, drive kinematics and odometry (pure)."""

from __future__ import annotations

import math

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from robot_daemon.hardware import roboteq
from robot_daemon.hardware.config import MotorsConfig

GEOM = MotorsConfig(wheel_radius=0.1, track=0.5, counts_per_rev=2048, gear_ratio=20, max_rpm=3000)


def test_command_strings() -> None:
    assert roboteq.motor_command("G", 1, -250) == b"!G 1 -250\r"
    assert roboteq.motor_command("S", 2, 120) == b"!S 2 120\r"
    assert roboteq.query("C") == b"?C\r"
    assert roboteq.query("C", 2) == b"?C 2\r"
    assert roboteq.config_command("RWD", 500) == b"^RWD 500\r"
    with pytest.raises(ValueError):
        roboteq.motor_command("G", 3, 0)


def test_twist_to_g_and_s_commands() -> None:
    # 0.5 m/s straight: wheel 5 rad/s = 47.75 rpm, motor 954.9 rpm of 3000.
    g = roboteq.twist_to_command(GEOM, 0.5, 0.0, "G")
    assert (g.left, g.right, g.clamped) == (318, 318, False)
    s = roboteq.twist_to_command(GEOM, 0.5, 0.0, "S")
    assert (s.left, s.right) == (955, 955)
    # Pure rotation at 1 rad/s: wheels at -/+ 0.25 m/s.
    r = roboteq.twist_to_command(GEOM, 0.0, 1.0, "S")
    assert r.left == -r.right == -round(GEOM.motor_rpm(0.25))


def test_clamping_keeps_curvature() -> None:
    cmd = roboteq.twist_to_command(GEOM, 3.0, 2.0, "G")  # left 2.5, right 3.5 m/s: too fast
    assert cmd.clamped and cmd.scale < 1.0
    assert cmd.right == 1000
    assert cmd.left / cmd.right == pytest.approx(2.5 / 3.5, abs=2e-3)
    nan = roboteq.twist_to_command(GEOM, math.nan, 0.0, "G")
    assert (nan.left, nan.right) == (0, 0)


@settings(max_examples=200)
@given(st.floats(-5, 5), st.floats(-10, 10), st.sampled_from(["G", "S"]))
def test_commands_never_exceed_limits(v: float, w: float, kind: str) -> None:
    cmd = roboteq.twist_to_command(GEOM, v, w, kind)
    limit = 1000 if kind == "G" else 3000
    assert abs(cmd.left) <= limit and abs(cmd.right) <= limit


def test_reply_parsing() -> None:
    assert roboteq.parse_query_reply(b"C=123:-45", "C") == (123, -45)
    v = roboteq.parse_voltages(b"V=135:296:4950")
    assert (v.internal, v.battery, v.five_volt) == (13.5, 29.6, 4.95)
    # ?BA is battery CURRENT in amps x10 per channel, summed; not a voltage.
    assert roboteq.parse_battery_current(b"BA=22:-5") == pytest.approx(1.7)
    assert roboteq.parse_fault_flags(b"FF=20") == 20
    assert roboteq.fault_names(20) == ["undervoltage", "emergency stop"]
    for bad, name in ((b"C=12:x", "C"), (b"BA=3", "V"), (b"FF=300", "FF"), (b"\xff\x00", "C")):
        with pytest.raises(roboteq.RoboteqError):
            if name == "FF":
                roboteq.parse_fault_flags(bad)
            else:
                roboteq.parse_query_reply(bad, name)


def test_counter_wrap() -> None:
    assert roboteq.counter_delta(-(2**31) + 5, 2**31 - 5) == 10
    assert roboteq.counter_delta(2**31 - 5, -(2**31) + 5) == -10
    assert roboteq.counter_delta(100, 40) == 60


def _counts(metres: float) -> int:
    return round(metres / GEOM.metres_per_count_lr[0])


def test_odometry_straight_line() -> None:
    odo = roboteq.WheelOdometry(GEOM)
    odo.update(0, 0, 0.0)
    state = odo.update(_counts(1.0), _counts(1.0), 2.0)
    assert state.pose.x == pytest.approx(1.0, abs=1e-4)
    assert state.pose.y == pytest.approx(0.0, abs=1e-12)
    assert state.linear == pytest.approx(0.5, abs=1e-4)
    assert state.angular == pytest.approx(0.0, abs=1e-9)


def test_odometry_rotation_in_place() -> None:
    odo = roboteq.WheelOdometry(GEOM)
    odo.update(1000, 1000, 0.0)
    arc = math.pi / 2 * GEOM.track / 2  # wheel travel for a quarter turn
    state = odo.update(1000 - _counts(arc), 1000 + _counts(arc), 1.0)
    assert state.pose.yaw == pytest.approx(math.pi / 2, abs=1e-3)
    assert math.hypot(state.pose.x, state.pose.y) < 1e-9
    assert state.angular == pytest.approx(math.pi / 2, abs=1e-3)


def test_odometry_arc_matches_closed_form_in_one_or_many_steps() -> None:
    # Constant twist v = 0.4 m/s, w = 0.5 rad/s for 4 s: circle of radius 0.8 m.
    v, w, t = 0.4, 0.5, 4.0
    d_l, d_r = ((v - w * GEOM.track / 2) * t, (v + w * GEOM.track / 2) * t)
    expected = Pose2D(v / w * math.sin(w * t), v / w * (1 - math.cos(w * t)), w * t)
    for steps in (1, 7, 100):
        odo = roboteq.WheelOdometry(GEOM)
        odo.update(0, 0, 0.0)
        for k in range(1, steps + 1):
            state = odo.update(_counts(d_l * k / steps), _counts(d_r * k / steps), t * k / steps)
        assert state.pose.x == pytest.approx(expected.x, abs=2e-4)
        assert state.pose.y == pytest.approx(expected.y, abs=2e-4)
        assert state.pose.yaw == pytest.approx(expected.yaw, abs=1e-3)


def test_odometry_across_counter_wrap_and_signs() -> None:
    odo = roboteq.WheelOdometry(GEOM, left_sign=-1, right_sign=1)
    start = 2**31 - 100
    odo.update(-start, start, 0.0)
    n = _counts(0.5)
    left = -(start + n)  # mirrored motor counts down when driving forwards
    right = (start + n + 2**31) % 2**32 - 2**31  # wrapped past +2^31
    state = odo.update(left, right, 1.0)
    assert state.pose.x == pytest.approx(0.5, abs=1e-4)
    assert state.pose.yaw == pytest.approx(0.0, abs=1e-9)


def test_state_of_charge() -> None:
    assert roboteq.state_of_charge(33.6, 0.0, 8, 0.08) == pytest.approx(1.0)
    assert roboteq.state_of_charge(24.0, 0.0, 8, 0.08) == pytest.approx(0.0)
    # Under load the terminal voltage sags; the I R correction gives the rest value back.
    assert roboteq.state_of_charge(29.84 - 5 * 0.08, 5.0, 8, 0.08) == pytest.approx(0.5)


def test_unequal_wheel_radii_make_equal_counts_curve_and_commands_compensate() -> None:
    """UMBmark's type-B error: a right wheel 2 % larger turns left on equal counts; per-wheel
    radii in the geometry put that in the odometry, and the command asks the larger wheel for
    proportionally fewer rpm so a straight twist stays straight."""

    geom = msgspec.structs.replace(GEOM, wheel_radius_left=0.1, wheel_radius_right=0.102)
    assert geom.radii == (0.1, 0.102)
    assert geom.metres_per_count_lr[1] / geom.metres_per_count_lr[0] == pytest.approx(1.02)
    odo = roboteq.WheelOdometry(geom)
    odo.update(0, 0, 0.0)
    n = _counts(2.0)  # 2 m of nominal-wheel travel on each side
    state = odo.update(n, n, 4.0)
    d_l, d_r = n * geom.metres_per_count_lr[0], n * geom.metres_per_count_lr[1]
    assert state.pose.yaw == pytest.approx((d_r - d_l) / geom.track, rel=1e-9)
    assert state.pose.yaw > 0.0  # curves left
    cmd = roboteq.twist_to_command(geom, 0.25, 0.0, "S")
    assert cmd.left / cmd.right == pytest.approx(1.02, abs=2e-3)
    # equal radii given explicitly change nothing
    same = msgspec.structs.replace(GEOM, wheel_radius_left=0.1, wheel_radius_right=0.1)
    assert roboteq.twist_to_command(same, 0.2, 0.3, "G") == roboteq.twist_to_command(
        GEOM, 0.2, 0.3, "G"
    )
    with pytest.raises(ValueError, match="wheel_radius_left"):
        msgspec.structs.replace(GEOM, wheel_radius_left=0.0)
