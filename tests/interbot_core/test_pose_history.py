from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from interbot_core.pose_history import PoseHistory


def test_interpolates_between_the_poses_around_a_stamp() -> None:
    h = PoseHistory()
    h.add(1.0, Pose2D(0.0, 0.0, 0.0))
    h.add(2.0, Pose2D(1.0, 2.0, 1.0))
    p = h.at(1.25)
    assert p is not None
    assert (p.x, p.y, p.yaw) == pytest.approx((0.25, 0.5, 0.25))


def test_yaw_goes_the_short_way_across_pi() -> None:
    h = PoseHistory()
    h.add(0.0, Pose2D(0.0, 0.0, math.pi - 0.1))
    h.add(1.0, Pose2D(0.0, 0.0, -math.pi + 0.1))
    p = h.at(0.5)
    assert p is not None and abs(abs(p.yaw) - math.pi) < 1e-9


def test_unknown_times_give_none_not_a_guess() -> None:
    h = PoseHistory(max_hold=0.25)
    assert h.at(5.0) is None
    h.add(1.0, Pose2D(0.0, 0.0, 0.0))
    h.add(2.0, Pose2D(1.0, 0.0, 0.0))
    assert h.at(0.5) is None  # older than the history
    assert h.at(2.2) == Pose2D(1.0, 0.0, 0.0)  # held briefly
    assert h.at(2.5) is None  # too far past the newest


def test_a_clock_going_back_resets_the_history() -> None:
    h = PoseHistory()
    h.add(10.0, Pose2D(5.0, 0.0, 0.0))
    h.add(1.0, Pose2D(0.0, 0.0, 0.0))  # the robot restarted
    assert len(h) == 1 and h.at(1.0) == Pose2D(0.0, 0.0, 0.0)


@given(st.lists(st.floats(0.0, 100.0), min_size=2, max_size=40, unique=True), st.floats(0, 1))
def test_interpolated_x_stays_between_its_neighbours(stamps: list[float], f: float) -> None:
    h = PoseHistory(capacity=64)
    stamps.sort()
    for t in stamps:
        h.add(t, Pose2D(t * 2.0, 0.0, 0.0))  # x grows with time
    t = stamps[0] + f * (stamps[-1] - stamps[0])
    p = h.at(t)
    assert p is not None and p.x == pytest.approx(2.0 * t, abs=1e-6)
