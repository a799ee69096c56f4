"""When a goal of a route counts as reached: the robot's one rule, whoever drives.

The goal logic of the thesis's ``clock()`` (§5.3.6, Fig. 5.12, "Single Goals"): moving onto
every intermediate goal and turning to its orientation is wasteful, so an intermediate goal
counts as reached as soon as the robot is within ``approach_tolerance`` of its position and the
next one is driven to; the final goal when the robot is within ``xy_tolerance`` of its position
*and* ``yaw_tolerance`` of its heading (Table 6.3: 0.5 m and 0.1 rad), Nav2's simple goal checker.

The navigator applies it while it drives (it turns in place once inside the final goal's xy
tolerance); the stack applies it while the route is suspended and someone else drives (an
operator, shared control) so progress is judged on the robot in every case. The Base Station
only mirrors what the robot reports on ``route_progress``; it has no goal logic of its own.
"""

from __future__ import annotations

from collections.abc import Sequence

from interbot_core.geometry import Pose2D, wrap_angle


def next_goal_index(
    goals: Sequence[Pose2D], index: int, pose: Pose2D, approach_tolerance: float
) -> int:
    """The goal to drive to from ``pose``: past every intermediate goal from ``index`` on that
    lies within ``approach_tolerance`` [m]; never past the final goal."""
    last = len(goals) - 1
    while index < last and pose.distance_to(goals[index]) <= approach_tolerance:
        index += 1
    return index


def final_goal_reached(
    pose: Pose2D, goal: Pose2D, xy_tolerance: float, yaw_tolerance: float
) -> bool:
    """Whether ``pose`` is inside the final goal's position [m] and heading [rad] tolerance."""
    return (
        pose.distance_to(goal) <= xy_tolerance
        and abs(wrap_angle(pose.yaw - goal.yaw)) <= yaw_tolerance
    )
