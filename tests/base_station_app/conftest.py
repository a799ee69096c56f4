"""Fixtures for the Base Station tests: a fake robot (`RobotLink` on a loopback zenoh session),
a station controller connected to it with a controllable clock, and a raw tablet socket."""

from __future__ import annotations

import json
import math
import socket
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import zenoh

from base_station_app.station_controller import StationController, Timing
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.supervisor import SupervisorState
from interbot_core.topics import ConfigMsg, PoseMsg, RouteMsg, RouteProgress, Topic
from interbot_core.topological_map import TopologicalMap, load_topological_map
from interbot_link import Command, RobotLink, session_config

REPO = Path(__file__).resolve().parents[2]
TOPO_PATH = REPO / "maps" / "isr_floor0_topo.yaml"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


class FakeClock:
    """A monotonic clock the test advances by hand [s]."""

    def __init__(self, now: float = 100.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now

    def advance(self, dt: float) -> float:
        self.now += dt
        return self.now


@dataclass
class FakeRobot:
    """A robot made of a `RobotLink`: publishes what the test asks and records commands."""

    link: RobotLink
    endpoint: str
    session: zenoh.Session
    commands: list[Command] = field(default_factory=list)

    def poll(self) -> list[Command]:
        new = self.link.poll_commands()
        self.commands.extend(new)
        return new

    def of(self, topic: str) -> list[object]:
        self.poll()
        return [c.message for c in self.commands if str(c.topic) == topic]

    def publish_pose(self, x: float, y: float, yaw: float, state: str = "ok") -> None:
        self.link.publish(Topic.POSE, PoseMsg(x, y, yaw, state=state))

    def report_arrival(self) -> bool:
        """Say the last route received is done, as the daemon does on ``route_progress`` (the
        station has no goal logic of its own); False before any route arrived."""
        routes = [r for r in self.of("route") if isinstance(r, RouteMsg)]
        if not routes:
            return False
        last = len(routes[-1].waypoints) - 1
        self.link.publish(
            Topic.ROUTE_PROGRESS, RouteProgress(routes[-1].route_id, last, True, "succeeded")
        )
        return True

    def publish_scan(self) -> None:
        n = 271
        ranges = np.full(n, 3.0, dtype=np.float32)
        ranges[::10] = np.nan
        self.link.publish_scan(
            LaserScan(0.0, -3 * math.pi / 4, 1.5 * math.pi / (n - 1), 0.1, 30.0, ranges)
        )


@pytest.fixture(scope="session")
def topo() -> TopologicalMap:
    return load_topological_map(TOPO_PATH)


@pytest.fixture
def robot() -> Iterator[FakeRobot]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = zenoh.open(session_config([endpoint], []))
    link = RobotLink(session, "r1")
    try:
        fake = FakeRobot(link, endpoint, session)
        yield fake
    finally:
        fake.link.close()
        session.close()


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def station(
    qtbot, robot: FakeRobot, topo: TopologicalMap, clock: FakeClock
) -> Iterator[StationController]:
    """A controller connected to the fake robot, its tablet server listening on a free port;
    timers NOT started: tests call ``tick()`` / ``poll_link()`` (or start them)."""
    session = zenoh.open(session_config([], [robot.endpoint]))
    controller = StationController(
        topo,
        session,
        topo_path=TOPO_PATH,
        clock=clock,
        tablet_port=0,
        timing=Timing(clock_ms=100, frame_ms=10, ping_ms=100, choice_grace_ms=0),
    )
    assert controller.start(timers=False)

    def selected() -> bool:
        controller.poll_link()
        return controller.selected_robot == "r1"

    qtbot.waitUntil(selected, timeout=10_000)
    try:
        yield controller
    finally:
        controller.shutdown()
        session.close()


@pytest.fixture
def linked(qtbot, station: StationController, robot: FakeRobot) -> StationController:
    """The station once the robot receives its commands (subscriptions propagated)."""

    def ok() -> bool:
        station.robot_link.resend_pending(
            station.selected
        )  # the stop intent (release of the start latch) and config
        sent = station._send(Topic.CONFIG, ConfigMsg({"max_linear_speed": 0.5}))
        return sent and not station.selected.stop_assert_pending

    qtbot.waitUntil(ok, timeout=10_000)

    def quiet() -> bool:  # everything sent so far has arrived
        qtbot.wait(50)
        return not robot.poll()

    qtbot.waitUntil(quiet, timeout=10_000)
    robot.commands.clear()
    return station


@pytest.fixture
def localise(qtbot, station: StationController, robot: FakeRobot):
    """``localise(pose)``: the robot publishes ``pose`` and the station has received it."""

    def do(pose: Pose2D, state: str = "ok") -> None:
        robot.publish_pose(pose.x, pose.y, pose.yaw, state)

        def seen() -> bool:
            station.poll_link()
            p = station.selected.state.pose
            return p is not None and (p.x, p.y, p.state) == (pose.x, pose.y, state)

        qtbot.waitUntil(seen, timeout=10_000)

    return do


class TabletClient:
    """A raw `socket.socket` tablet speaking bare JSON objects (no newlines)."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=2.0)
        self.sock.setblocking(False)
        self.buffer = b""
        self.received: list[dict] = []

    def send_raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def send(self, obj: dict) -> None:
        self.sock.sendall(json.dumps(obj).encode())

    def pump(self) -> bool:
        """Read what arrived; True if the peer closed."""
        closed = False
        while True:
            try:
                chunk = self.sock.recv(65536)
            except BlockingIOError:
                break
            except ConnectionResetError:
                closed = True
                break
            if not chunk:
                closed = True
                break
            self.buffer += chunk
        *lines, self.buffer = self.buffer.split(b"\n")
        self.received.extend(json.loads(line) for line in lines if line.strip())
        return closed

    def of(self, key: str) -> list[object]:
        self.pump()
        return [m[key] for m in self.received if key in m]

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def tablet_factory(station: StationController) -> Iterator:
    clients: list[TabletClient] = []

    def make() -> TabletClient:
        c = TabletClient(station.tablet.port)
        clients.append(c)
        return c

    yield make
    for c in clients:
        c.close()


def robot_arrives(qtbot, station: StationController, robot: FakeRobot) -> None:
    """The robot reports the route it got done; the station mirrors it, then runs its clock."""
    qtbot.waitUntil(robot.report_arrival, timeout=10_000)

    def mirrored() -> bool:
        station.poll_link()
        return station.selected.supervisor.state not in (
            SupervisorState.NAVIGATING,
            SupervisorState.PAUSED,
        )

    qtbot.waitUntil(mirrored, timeout=10_000)
    station.tick()
