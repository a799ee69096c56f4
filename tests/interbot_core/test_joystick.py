"""Tests for interbot_core.joystick (thesis eqs. 5.1/5.2)."""

from __future__ import annotations

import math

import hypothesis.strategies as st
import pytest
from hypothesis import given, settings

from interbot_core.joystick import JoystickError, JoystickState, joystick_command

C = (200.0, 150.0)
R = 100.0


def cmd(px: float, py: float, lmax: float = 0.5, amax: float = 1.0) -> tuple[float, float]:
    return joystick_command(C[0], C[1], px, py, R, lmax, amax)


def test_equations_inside_the_circle() -> None:
    # Half-way up and a quarter to the left: linear = 0.5 * 0.5, angular = 0.25 * 1.0.
    assert cmd(175.0, 100.0) == pytest.approx((0.25, 0.25))
    assert cmd(*C) == (0.0, 0.0)


def test_directions_follow_rep103_with_screen_y_down() -> None:
    assert cmd(200.0, 60.0)[0] > 0  # above centre: forward
    assert cmd(200.0, 240.0)[0] < 0  # below: backward
    assert cmd(120.0, 150.0)[1] > 0  # left of centre: turn left (counter-clockwise)
    assert cmd(280.0, 150.0)[1] < 0  # right: turn right


def test_outside_is_clamped_radially_to_the_edge() -> None:
    assert cmd(200.0, -1000.0) == pytest.approx((0.5, 0.0))  # straight up, far away
    lin, ang = cmd(200.0 - 300.0, 150.0 - 400.0)  # direction (3, 4) / 5, 5 radii away
    assert lin == pytest.approx(0.8 * 0.5)
    assert ang == pytest.approx(0.6 * 1.0)


def test_validation() -> None:
    with pytest.raises(JoystickError, match=r"joystick\.radius = 0\.0 px is outside the allowed"):
        joystick_command(0, 0, 1, 1, 0.0, 1, 1)
    with pytest.raises(
        JoystickError, match=r"joystick\.linear_max = -1 m/s is outside .*\[0, inf\)"
    ):
        joystick_command(0, 0, 1, 1, 1.0, -1, 1)
    with pytest.raises(JoystickError, match=r"joystick\.angular_max must be a finite number"):
        joystick_command(0, 0, 1, 1, 1.0, 1, math.nan)
    with pytest.raises(JoystickError, match=r"joystick\.pressed\.x must be a finite number \[px\]"):
        joystick_command(0, 0, math.inf, 1, 1.0, 1, 1)
    assert joystick_command(0, 0, 0, -1, 1.0, 0.0, 0.0) == (0.0, 0.0)


def test_state_press_move_release() -> None:
    joy = JoystickState(C[0], C[1], R, 0.5, 1.0)
    assert not joy.pressed
    assert joy.press(200.0, 50.0) == pytest.approx((0.5, 0.0))
    assert joy.press(100.0, 150.0) == pytest.approx((0.0, 1.0))  # a drag presses again
    assert joy.set_limits(0.2, 0.4) == pytest.approx((0.0, 0.4))
    joy.set_geometry(100.0, 150.0, 50.0)
    assert joy.command == (0.0, 0.0)
    assert joy.release() == (0.0, 0.0)
    assert joy.command == (0.0, 0.0) and not joy.pressed
    with pytest.raises(JoystickError):
        joy.set_limits(-0.1, 0.4)
    with pytest.raises(JoystickError):
        JoystickState(0, 0, -1, 1, 1)


coord = st.floats(-1e4, 1e4)


@settings(max_examples=200, deadline=None)
@given(
    cx=coord,
    cy=coord,
    px=coord,
    py=coord,
    radius=st.floats(1e-3, 1e3),
    lmax=st.floats(1e-3, 5.0),
    amax=st.floats(1e-3, 5.0),
)
def test_normalised_command_never_exceeds_one(
    cx: float, cy: float, px: float, py: float, radius: float, lmax: float, amax: float
) -> None:
    lin, ang = joystick_command(cx, cy, px, py, radius, lmax, amax)
    nl, na = lin / lmax, ang / amax
    assert -1.0 <= nl <= 1.0
    assert -1.0 <= na <= 1.0
    assert math.hypot(nl, na) <= 1.0 + 1e-12
    # Sign follows the equations.
    if py < cy and nl != 0.0:
        assert nl > 0
    if px < cx and na != 0.0:
        assert na > 0
    # Inside the circle, eqs. 5.1/5.2 hold unchanged.
    if math.hypot(cx - px, cy - py) <= radius:
        assert lin == pytest.approx((cy - py) / radius * lmax, abs=1e-9)
        assert ang == pytest.approx((cx - px) / radius * amax, abs=1e-9)
