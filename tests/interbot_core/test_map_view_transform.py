"""Tests for interbot_core.map_view_transform (thesis Algorithm 3, generalised)."""

from __future__ import annotations

import math

import hypothesis.strategies as st
import pytest
from hypothesis import given, settings

from interbot_core.map_view_transform import MapViewError, MapViewTransform


def thesis_algorithm_3(x: float, y: float, width: float, height: float) -> tuple[float, float]:
    """Thesis Algorithm 3 verbatim (no y flip)."""
    h_scale = height / 35
    w_scale = width / 70
    return ((x + 35) * w_scale, (y + 14.25) * h_scale)


@pytest.mark.parametrize(("width", "height"), [(1280, 800), (700, 350), (1024, 600)])
@pytest.mark.parametrize(("x", "y"), [(0.0, 0.0), (-35.0, -14.25), (35.0, 20.75), (12.3, -4.5)])
def test_reproduces_thesis_constants_with_y_flipped(
    width: int, height: int, x: float, y: float
) -> None:
    view = MapViewTransform(-35.0, -14.25, 70.0, 35.0, width, height, keep_aspect=False)
    assert view.scale_x == pytest.approx(width / 70)
    assert view.scale_y == pytest.approx(height / 35)
    thesis_x, thesis_y = thesis_algorithm_3(x, y, width, height)
    px, py = view.world_to_widget(x, y)
    assert px == pytest.approx(thesis_x)
    # The thesis did not flip y; Qt's y points down, so we do: ours = height - thesis.
    assert py == pytest.approx(height - thesis_y)


def test_keep_aspect_letterboxes_and_centres() -> None:
    view = MapViewTransform(-35.0, -14.25, 70.0, 35.0, 1000, 1000)
    assert view.scale == view.scale_x == view.scale_y == pytest.approx(1000 / 70)
    assert view.offset_x == pytest.approx(0.0)
    assert view.offset_y == pytest.approx((1000 - 35 * 1000 / 70) / 2)  # 250 px bands
    left, top, w, h = view.map_rect_px()
    assert (left, top, w, h) == pytest.approx((0.0, 250.0, 1000.0, 500.0))
    # Map corners land on the rect's corners: lower-left world -> bottom-left pixel.
    assert view.world_to_widget(-35.0, -14.25) == pytest.approx((0.0, 750.0))
    assert view.world_to_widget(35.0, 20.75) == pytest.approx((1000.0, 250.0))
    # Map centre -> widget centre.
    assert view.world_to_widget(0.0, 3.25) == pytest.approx((500.0, 500.0))


def test_north_up_and_yaw_angles() -> None:
    view = MapViewTransform(0.0, 0.0, 10.0, 10.0, 100, 100)
    # Moving +y in the world moves up the screen (smaller py).
    assert view.world_to_widget(5.0, 6.0)[1] < view.world_to_widget(5.0, 5.0)[1]
    assert view.yaw_to_widget_angle(0.0) == pytest.approx(0.0)
    assert view.yaw_to_widget_angle(math.pi / 2) == pytest.approx(-math.pi / 2)  # screen up
    assert view.yaw_to_widget_angle(math.pi) == pytest.approx(math.pi)
    stretched = MapViewTransform(0.0, 0.0, 10.0, 10.0, 200, 100, keep_aspect=False)
    # 45 deg in the world is flatter on a view stretched 2:1 horizontally.
    assert stretched.yaw_to_widget_angle(math.pi / 4) == pytest.approx(-math.atan2(1, 2))
    assert stretched.scale == pytest.approx(10.0)


def test_validation() -> None:
    with pytest.raises(
        MapViewError,
        match=r"map view.map_width_m = 0 m is outside the allowed range \(0, inf\) m",
    ):
        MapViewTransform(0, 0, 0, 1, 10, 10)
    with pytest.raises(
        MapViewError, match=r"widget_height_px = -1 px is outside the allowed range \(0, inf\) px"
    ):
        MapViewTransform(0, 0, 1, 1, 10, -1)
    with pytest.raises(
        MapViewError, match=r"map view.map_origin_x must be a finite number, got nan"
    ):
        MapViewTransform(math.nan, 0, 1, 1, 10, 10)


maps = st.tuples(
    st.floats(-1e3, 1e3),
    st.floats(-1e3, 1e3),
    st.floats(0.5, 500.0),
    st.floats(0.5, 500.0),
    st.integers(10, 4000),
    st.integers(10, 4000),
    st.booleans(),
)


@settings(max_examples=200, deadline=None)
@given(m=maps, u=st.floats(-0.5, 1.5), v=st.floats(-0.5, 1.5), yaw=st.floats(-10, 10))
def test_points_and_headings_land_where_drawn(
    m: tuple[float, float, float, float, int, int, bool], u: float, v: float, yaw: float
) -> None:
    view = MapViewTransform(*m)
    x = view.map_origin_x + u * view.map_width_m
    y = view.map_origin_y + v * view.map_height_m
    px, py = view.world_to_widget(x, y)
    if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0:  # inside the map rectangle
        tol = 1e-6
        assert -tol <= px <= view.widget_width_px + tol
        assert -tol <= py <= view.widget_height_px + tol
    angle = view.yaw_to_widget_angle(yaw)
    assert -math.pi < angle <= math.pi
    # The heading is drawn the way the robot moves on screen: along a step in the yaw direction.
    qx, qy = view.world_to_widget(x + math.cos(yaw), y + math.sin(yaw))
    assert math.cos(math.atan2(qy - py, qx - px) - angle) == pytest.approx(1.0, abs=1e-9)
    if view.keep_aspect:
        assert view.scale_x == view.scale_y
        assert min(view.offset_x, view.offset_y) == pytest.approx(0.0, abs=1e-9)
