"""`FleetWatch`: the station's light watch on robots it does not follow (issue 14), on loopback."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack

import pytest

from interbot_core.topics import PoseMsg, RobotIdError, RouteMsg, RouteProgress, Topic
from interbot_link import RobotLink, open_session
from interbot_link.fleet_watch import WATCH_TOPICS, FleetWatch, NotWatchedError
from interbot_link.robot import LinkClosedError


def test_a_watched_robot_is_seen_lightly_and_commanded(
    free_tcp_port: Callable[[], int], wait_until: Callable[..., None]
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    with ExitStack() as stack:
        robot = RobotLink(stack.enter_context(open_session([endpoint], [])), "w1")
        stack.callback(robot.close)
        watch = FleetWatch(stack.enter_context(open_session([], [endpoint])))
        stack.callback(watch.close)
        watch.set_watched({"w1"})
        assert watch.watched == {"w1"}
        route = RouteMsg(5, ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)))
        wait_until(lambda: watch.send("w1", Topic.ROUTE, route), 5.0, "the robot to subscribe")
        wait_until(lambda: any(c.topic is Topic.ROUTE for c in robot.poll_commands()), 5.0, "route")

        got: list[object] = []

        def heard() -> bool:
            robot.publish(Topic.POSE, PoseMsg(1.0, 2.0, 0.0, state="ok"))
            robot.publish(Topic.ROUTE_PROGRESS, RouteProgress(5, 1))
            got.extend(m.topic for m in watch.poll() if m.robot_id == "w1")
            return Topic.POSE in got and Topic.ROUTE_PROGRESS in got

        wait_until(heard, 5.0, "pose and route progress")
        assert Topic.SCAN not in WATCH_TOPICS and Topic.IMAGE not in WATCH_TOPICS  # light only

        with pytest.raises(NotWatchedError):
            watch.send("w2", Topic.ROUTE, route)
        with pytest.raises(RobotIdError):
            watch.set_watched({"bad id!"})
        assert watch.watched == {"w1"}  # a refused set changes nothing
        watch.set_watched(set())
        assert watch.watched == frozenset()
        watch.close()
        with pytest.raises(LinkClosedError):
            watch.send("w1", Topic.ROUTE, route)
