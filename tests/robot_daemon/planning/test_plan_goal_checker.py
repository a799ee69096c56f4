"""The robot's one goal rule (`robot_daemon.planning.goal_checker`), alone and in the stack while
an operator drives: the route's progress is judged on the robot whoever drives."""

from __future__ import annotations

import math

import pytest

from interbot_core.geometry import Pose2D
from interbot_core.topics import RouteMsg
from robot_daemon.planning.goal_checker import final_goal_reached, next_goal_index
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem

ROUTE = (Pose2D(0.0, 0.0, 0.0), Pose2D(5.0, 0.0, 0.0), Pose2D(5.0, 5.0, math.pi / 2))


def test_intermediate_goals_pass_within_the_approach_tolerance_never_the_final() -> None:
    assert next_goal_index(ROUTE, 0, Pose2D(0.5, 0.0, 2.0), 1.0) == 1  # heading does not matter
    assert next_goal_index(ROUTE, 0, Pose2D(1.5, 0.0, 0.0), 1.0) == 0
    assert next_goal_index(ROUTE, 0, Pose2D(2.5, 0.0, 0.0), 3.0) == 2  # several at once
    assert next_goal_index(ROUTE, 2, Pose2D(5.0, 5.0, 0.0), 1.0) == 2  # the final stays
    assert next_goal_index(ROUTE[2:], 0, Pose2D(5.0, 5.0, 0.0), 1.0) == 0
    assert next_goal_index(ROUTE, 1, Pose2D(0.0, 0.0, 0.0), 1.0) == 1  # never backwards


@pytest.mark.parametrize(
    ("pose", "reached"),
    [
        (Pose2D(5.0, 4.4, math.pi / 2), False),  # 0.6 m away
        (Pose2D(5.0, 4.6, 0.0), False),  # inside 0.5 m, heading wrong
        (Pose2D(5.0, 4.6, math.pi / 2 - 0.15), False),  # 0.15 rad off
        (Pose2D(5.0, 4.6, math.pi / 2 - 0.05), True),
        (Pose2D(5.0, 5.0, math.pi / 2 + 2 * math.pi - 0.05), True),  # angles wrap
    ],
)
def test_the_final_goal_needs_position_and_heading(pose: Pose2D, reached: bool) -> None:
    assert final_goal_reached(pose, ROUTE[-1], 0.5, 0.1) is reached


def test_an_operator_driving_the_route_finishes_it_on_the_robot() -> None:
    """Autonomy paused (pure teleoperation): the operator drives west from the Main Entrance; the
    stack passes the intermediate goal and reports the route succeeded, as the navigator would."""
    options = ScenarioOptions(people=0, ideal_world=True)
    system = SimulatedSystem(options, start_node=0, autonomy=False)
    system.localise()
    stack, start = system.stack, system.start_pose  # (-29.5, 3.7), facing west (yaw pi)
    waypoints = ((start.x - 1.0, start.y, math.pi), (start.x - 2.0, start.y, math.pi))
    stack.set_route(RouteMsg(7, waypoints, (), 0.3, 0.3, 0.2), system.now)
    indices = []

    def drive() -> bool:
        stack.on_twist("station_vel", 0.3, 0.0, system.now)
        route = stack.route
        assert route is not None
        indices.append(route.index)
        assert stack.navigator.state.value == "idle"  # autonomy never drives
        return route.state == "succeeded"

    assert system.run_until(drive, 15.0)
    assert indices[0] == 0 and 1 in indices
    route = stack.route
    assert route is not None and route.index == 1 and route.reason == "goal reached"
    pose = stack.pose
    assert pose is not None and pose.distance_to(Pose2D(*waypoints[-1])) <= 0.3
