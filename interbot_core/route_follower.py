"""Follow a route of waypoints: approach intermediate goals, reach the final one exactly.

The goal logic of the Base Station's ``clock()`` (thesis §5.3.6, Fig. 5.12, "Single Goals"):
moving onto every intermediate goal and turning to its orientation is wasteful, so an
intermediate goal counts as reached as soon as the robot is within ``approach_tolerance`` of its
position, and the next goal is published. The final goal is reached only when the robot is within
``goal_tolerance`` of its position *and* ``yaw_tolerance`` of its heading (defaults: thesis
Table 6.3, 0.5 m and 0.1 rad).

:class:`RouteFollower` is pure (no time, no I/O): it runs in the robot daemon, so the robot
finishes its route when the station disappears, and in the station to report progress.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

from interbot_core.geometry import Pose2D, wrap_angle

logger = logging.getLogger(__name__)

DEFAULT_APPROACH_TOLERANCE = 1.0  # [m]
DEFAULT_GOAL_TOLERANCE = 0.5  # [m] thesis Table 6.3
DEFAULT_YAW_TOLERANCE = 0.1  # [rad] thesis Table 6.3


# The station sends the robot its arrival tolerances scaled by this, so that where the robot
# stops (inside its tolerance, judged on its own pose) the station's follower, judging the
# published pose against the full tolerance, agrees that the goal was reached.
ROBOT_TOLERANCE_SHARE = 0.8


@dataclass(frozen=True)
class FollowerState:
    """Result of one :meth:`RouteFollower.update`.

    ``current_index``/``current_target`` is the goal the robot should drive to now (the final
    waypoint once reached); ``advanced`` is True when the index moved in this update;
    ``passed`` lists the waypoint indices reached in this update, the final one included.
    """

    current_index: int
    current_target: Pose2D
    reached_final: bool
    advanced: bool
    passed: tuple[int, ...] = ()


class RouteFollower:
    """Tracks progress along ``waypoints`` (the last one is the final goal)."""

    def __init__(
        self,
        waypoints: Sequence[Pose2D],
        approach_tolerance: float = DEFAULT_APPROACH_TOLERANCE,
        goal_tolerance: float = DEFAULT_GOAL_TOLERANCE,
        yaw_tolerance: float = DEFAULT_YAW_TOLERANCE,
    ) -> None:
        if not waypoints:
            raise ValueError("RouteFollower needs at least one waypoint")
        for name, value in (
            ("approach_tolerance [m]", approach_tolerance),
            ("goal_tolerance [m]", goal_tolerance),
            ("yaw_tolerance [rad]", yaw_tolerance),
        ):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if yaw_tolerance > math.pi:
            raise ValueError(f"yaw_tolerance [rad] must be <= pi, got {yaw_tolerance!r}")
        self.waypoints: tuple[Pose2D, ...] = tuple(waypoints)
        self.approach_tolerance = approach_tolerance
        self.goal_tolerance = goal_tolerance
        self.yaw_tolerance = yaw_tolerance
        self._index = 0
        self._reached_final = False

    @property
    def current_index(self) -> int:
        return self._index

    @property
    def current_target(self) -> Pose2D:
        return self.waypoints[self._index]

    @property
    def reached_final(self) -> bool:
        return self._reached_final

    @property
    def is_final_target(self) -> bool:
        """True when the current target is the last waypoint."""
        return self._index == len(self.waypoints) - 1

    def update(self, pose: Pose2D) -> FollowerState:
        """Advance past every intermediate goal within ``approach_tolerance`` of ``pose``;
        mark the final goal reached once inside ``goal_tolerance`` and ``yaw_tolerance``.

        Reaching the final goal latches: later poses do not un-reach it.
        """
        start = self._index
        passed: list[int] = []
        last = len(self.waypoints) - 1
        if not self._reached_final:
            while self._index < last and (
                pose.distance_to(self.waypoints[self._index]) <= self.approach_tolerance
            ):
                passed.append(self._index)
                self._index += 1
            if self._index == last and self.final_reached_at(pose):
                self._reached_final = True
                passed.append(last)
                logger.debug("final goal %s reached at %s", self.waypoints[last], pose)
        return FollowerState(
            current_index=self._index,
            current_target=self.waypoints[self._index],
            reached_final=self._reached_final,
            advanced=self._index != start,
            passed=tuple(passed),
        )

    def final_reached_at(self, pose: Pose2D) -> bool:
        """Whether ``pose`` is inside the final goal's position and orientation tolerance."""
        goal = self.waypoints[-1]
        return (
            pose.distance_to(goal) <= self.goal_tolerance
            and abs(wrap_angle(pose.yaw - goal.yaw)) <= self.yaw_tolerance
        )

    def distance_to_target(self, pose: Pose2D) -> float:
        """Straight-line distance from ``pose`` to the current target [m]."""
        return pose.distance_to(self.current_target)

    def remaining_distance(self, pose: Pose2D) -> float:
        """Distance to the current target plus the remaining legs of the route [m]."""
        rest = self.waypoints[self._index :]
        return pose.distance_to(rest[0]) + sum(
            a.distance_to(b) for a, b in itertools.pairwise(rest)
        )
