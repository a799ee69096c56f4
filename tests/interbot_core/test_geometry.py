from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D, angle_diff, wrap_angle

finite = st.floats(-1e3, 1e3, allow_nan=False)
angles = st.floats(-50.0, 50.0, allow_nan=False)


@given(angles)
def test_wrap_angle_range_and_equivalence(a: float) -> None:
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)


def test_wrap_angle_edges() -> None:
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert angle_diff(0.1, -0.1) == pytest.approx(0.2)
    assert angle_diff(math.pi - 0.1, -math.pi + 0.1) == pytest.approx(-0.2)


@given(finite, finite, angles, finite, finite, angles)
def test_compose_inverse_roundtrip(
    x: float, y: float, a: float, dx: float, dy: float, da: float
) -> None:
    p = Pose2D(x, y, a)
    d = Pose2D(dx, dy, da)
    q = p.compose(d)
    back = q.relative_to(p)
    assert back.x == pytest.approx(d.x, abs=1e-6)
    assert back.y == pytest.approx(d.y, abs=1e-6)
    assert angle_diff(back.yaw, d.yaw) == pytest.approx(0.0, abs=1e-9)


def test_compose_known_values() -> None:
    p = Pose2D(1.0, 2.0, math.pi / 2)
    q = p.compose(Pose2D(1.0, 0.0, 0.0))  # one metre "forward" while facing +y
    assert (q.x, q.y) == pytest.approx((1.0, 3.0))
    assert p.distance_to(q) == pytest.approx(1.0)


def test_pose_rejects_non_finite() -> None:
    with pytest.raises(ValueError, match="yaw"):
        Pose2D(0.0, 0.0, float("nan"))
