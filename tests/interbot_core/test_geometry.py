from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
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


@dataclass(frozen=True)
class _DataclassPose:
    """`Pose2D` as the dataclass's own __init__ and a __post_init__ built it (before the
    speed work): the reference for its written-out constructor."""

    x: float
    y: float
    yaw: float

    def __post_init__(self) -> None:
        for name in ("x", "y", "yaw"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"Pose2D.{name} must be finite, got {value!r}")
        object.__setattr__(self, "yaw", wrap_angle(float(self.yaw)))
        object.__setattr__(self, "x", float(self.x))
        object.__setattr__(self, "y", float(self.y))


@given(finite, finite, angles)
def test_pose_constructor_equals_the_dataclass_post_init(x: float, y: float, a: float) -> None:
    for args in ((x, y, a), (int(x), np.float32(y), np.float64(a))):
        pose, ref = Pose2D(*args), _DataclassPose(*args)
        assert (pose.x, pose.y, pose.yaw) == (ref.x, ref.y, ref.yaw)
        assert all(type(v) is float for v in (pose.x, pose.y, pose.yaw))
    assert Pose2D(x=x, y=y, yaw=a) == Pose2D(x, y, a)
    assert dataclasses.replace(Pose2D(x, y, a), yaw=a + 7.0).yaw == wrap_angle(a + 7.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_pose_constructor_names_the_first_bad_field_as_before(bad: float) -> None:
    for args in ((bad, 0.0, 0.0), (0.0, bad, 0.0), (0.0, 0.0, bad), (bad, bad, bad)):
        with pytest.raises(ValueError) as new:
            Pose2D(*args)
        with pytest.raises(ValueError) as old:
            _DataclassPose(*args)
        assert str(new.value) == str(old.value)
