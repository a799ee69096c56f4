"""Tests for interbot_core.route_follower: approach tolerance, final position + yaw tolerance."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.geometry import Pose2D
from interbot_core.route_follower import RouteFollower

ROUTE = [Pose2D(0.0, 0.0, 0.0), Pose2D(10.0, 0.0, 0.0), Pose2D(10.0, 10.0, math.pi / 2)]


def test_defaults_are_thesis_table_6_3() -> None:
    follower = RouteFollower(ROUTE)
    assert (follower.approach_tolerance, follower.goal_tolerance, follower.yaw_tolerance) == (
        1.0,
        0.5,
        0.1,
    )


def test_intermediate_goals_advance_within_approach_tolerance_without_orientation() -> None:
    follower = RouteFollower(ROUTE)
    state = follower.update(Pose2D(-1.2, 0.0, 0.0))  # 1.2 m away from waypoint 0
    assert (state.current_index, state.advanced, state.passed) == (0, False, ())
    state = follower.update(Pose2D(-0.9, 0.3, 3.0))  # within 1 m, facing backwards: still fine
    assert (state.current_index, state.advanced, state.passed) == (1, True, (0,))
    assert state.current_target == ROUTE[1]
    assert follower.distance_to_target(Pose2D(5.0, 0.0, 0.0)) == pytest.approx(5.0)
    assert follower.remaining_distance(Pose2D(5.0, 0.0, 0.0)) == pytest.approx(15.0)
    state = follower.update(Pose2D(9.5, 0.5, -2.0))
    assert (state.current_index, state.reached_final) == (2, False)
    assert follower.is_final_target


def test_final_needs_position_and_orientation() -> None:
    follower = RouteFollower(ROUTE[2:])
    goal = ROUTE[2]
    assert not follower.update(Pose2D(goal.x, goal.y - 0.7, goal.yaw)).reached_final  # 0.7 m
    assert not follower.update(Pose2D(goal.x, goal.y - 0.3, goal.yaw + 0.2)).reached_final
    state = follower.update(Pose2D(goal.x + 0.2, goal.y - 0.3, goal.yaw - 0.09))
    assert state.reached_final and state.passed == (0,) and not state.advanced
    # latched: drifting away afterwards does not un-reach it, nor report it again
    again = follower.update(Pose2D(0.0, 0.0, 0.0))
    assert again.reached_final and again.passed == ()


def test_yaw_tolerance_wraps_around_pi() -> None:
    follower = RouteFollower([Pose2D(0.0, 0.0, math.pi)])
    assert follower.update(Pose2D(0.0, 0.0, -math.pi + 0.05)).reached_final


def test_several_waypoints_passed_in_one_update() -> None:
    close = [Pose2D(0.0, 0.0, 0.0), Pose2D(0.5, 0.0, 0.0), Pose2D(5.0, 0.0, 0.0)]
    state = RouteFollower(close).update(Pose2D(0.2, 0.0, 0.0))
    assert state.passed == (0, 1) and state.current_index == 2


def test_single_intermediate_reachable_by_final_only() -> None:
    """The final goal is never passed by the approach tolerance alone."""
    follower = RouteFollower([Pose2D(0.0, 0.0, 0.0), Pose2D(0.8, 0.0, 1.0)])
    state = follower.update(Pose2D(0.1, 0.0, 0.0))
    assert state.current_index == 1 and not state.reached_final


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"approach_tolerance": 0.0}, "approach_tolerance"),
        ({"goal_tolerance": -1.0}, "goal_tolerance"),
        ({"yaw_tolerance": math.nan}, "yaw_tolerance"),
        ({"yaw_tolerance": 4.0}, "must be <= pi"),
    ],
)
def test_invalid_tolerances(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RouteFollower(ROUTE, **kwargs)


def test_empty_route_rejected() -> None:
    with pytest.raises(ValueError, match="at least one waypoint"):
        RouteFollower([])


coords = st.floats(min_value=-15.0, max_value=15.0, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(coords, coords, coords), min_size=1, max_size=40))
def test_index_is_monotonic_and_final_only_inside_tolerance(
    poses: list[tuple[float, float, float]],
) -> None:
    follower = RouteFollower(ROUTE, approach_tolerance=3.0, goal_tolerance=2.0, yaw_tolerance=1.0)
    index = 0
    for x, y, yaw in poses:
        pose = Pose2D(x, y, yaw)
        was_reached = follower.reached_final
        state = follower.update(pose)
        assert state.current_index >= index
        index = state.current_index
        if state.reached_final and not was_reached:
            assert follower.final_reached_at(pose) and index == len(ROUTE) - 1
