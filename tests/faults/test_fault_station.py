"""Issue 11 faults: a station restarted mid-route, and a station that switches robots.

Two daemon processes (robots A and B):

1. station 1 sends A a route and is then shut down for good (a station restart: nothing of it
   survives); station 2 starts, a tablet connects to it and is told **the real state** (A is
   driving a route started before this station), not "idle"; the tablet's ``stop`` cancels it
   and A stops;
2. station 2 sends A a route and the operator switches to robot B: A keeps its route and task
   (each robot has its own supervisor, issue 14: nothing is cancelled by a change of view),
   **B receives no route**, and B's queue is its own (empty).
"""

from __future__ import annotations

import json
import socket
import time

import pytest

from interbot_core.supervisor import GoTo
from interbot_core.topics import Topic
from tests.faults.conftest import START_TIMEOUT

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]

A, B = "faultbot_a", "faultbot_b"


class RawTablet:
    """A thesis-style tablet socket: bare JSON objects out, newline-separated objects in."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        self.sock.setblocking(False)
        self.buffer = b""
        self.received: list[dict] = []

    def send(self, obj: dict) -> None:
        self.sock.sendall(json.dumps(obj).encode())

    def of(self, key: str) -> list:
        while True:
            try:
                chunk = self.sock.recv(65536)
            except BlockingIOError:
                break
            if not chunk:
                break
            self.buffer += chunk
        *lines, self.buffer = self.buffer.split(b"\n")
        self.received += [json.loads(line) for line in lines if line.strip()]
        return [m[key] for m in self.received if key in m]

    def close(self) -> None:
        self.sock.close()


def test_station_restart_and_robot_switch(rig) -> None:
    robot_a, robot_b = rig.daemon(A), rig.daemon(B)
    observer = rig.observer(robot_a, robot_b)
    station1 = rig.station(robot_a, robot=A)
    rig.online(station1, A)
    assert station1.submit(GoTo(14))
    rig.wait(lambda: observer.travelled(A, 0.0) > 0.2, 30.0, "robot A to drive its route")
    old_route = station1.selected.route.route_id

    # 1. The station restarts mid-route; the tablet connects to the new one.
    station1.destroyed_by_test()
    station2 = rig.station(robot_a, robot_b, robot=A)
    rig.online(station2, A)
    tablet = RawTablet(station2.tablet.port)
    rig.resources.append(tablet.close)
    rig.wait(
        lambda: any("started before this station" in s["task"] for s in tablet.of("status")),
        10.0,
        "the tablet to be told that A drives a route",
    )
    status = [s for s in tablet.of("status") if "started before" in s["task"]][-1]
    assert str(old_route) in status["task"] and "did not start" in status["message"]
    tablet.send({"stop": True})
    rig.wait(
        lambda: (p := observer.last(Topic.ROUTE_PROGRESS, A)) is not None and p.state == "canceled",
        10.0,
        "robot A to cancel the route",
    )
    rig.wait(
        lambda: (m := observer.last(Topic.MUX, A)) is not None and m.source is None,
        5.0,
        "robot A's motors to zero",
    )
    stopped = time.monotonic()
    # Braking and standing on the robot's clock (its stamps): on a loaded machine its simulated
    # time and the messages' arrival both lag this process's clock (a run at load 6 saw 1.3 cm
    # "after 1 s" of wall time). Watched until 1.5 s of robot time after the zero.
    zeroed = observer.zeroed_at(A)
    rig.wait(
        lambda: observer.newest_stamp(Topic.ODOM, A) >= zeroed + 1.5,
        10.0,
        "1.5 s of robot A's odometry after its motors' zero",
    )
    assert observer.travelled_robot_time(A, zeroed) < 0.1  # braking distance from 0.25 m/s
    assert observer.travelled_robot_time(A, zeroed + 1.0) == 0.0  # then standing
    assert rig.wait(lambda: not station2.selected.route_mirror.robot_running, 5.0, "idle") is None

    # 2. A new route for A, then the operator switches to B.
    assert station2.submit(GoTo(23))
    rig.wait(lambda: len(observer.routes_received(A, stopped)) == 1, 10.0, "A's new route")
    new_route = station2.selected.route.route_id
    assert new_route != old_route
    # The operator switches to a robot the station lists as present: B's daemon started with
    # A's but nothing waited for it so far (on a loaded machine it may come up seconds later).
    rig.wait(lambda: B in station2.fleet.online, START_TIMEOUT, "the station to see robot B")
    switched = time.monotonic()
    station2.select_robot(B)
    rig.wait(lambda: station2.robot_online and station2.selected_robot == B, 10.0, "B selected")
    rig.qtbot.wait(1500)
    assert not observer.robot_said(A, f"route {new_route} robot switched", switched)
    a = station2.fleet.mirror(A)
    assert a.route is not None and a.route.route_id == new_route  # A still drives it
    assert a.supervisor.current_task == GoTo(23)
    assert observer.travelled(A, switched) > 0.05  # and moves, watched, not followed
    assert observer.routes_received(B) == []  # robot 1's route never reaches robot 2
    assert station2.selected.supervisor.current_task is None
