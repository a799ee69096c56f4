"""Five simulated robots and one station through one zenoh router, robots coming and going.

Everything on 127.0.0.1 with OS-chosen ports: an `interbot_link.router` session, five robot
daemons (simulator, their own client sessions) and a station `StationLink` (a client), none of
which knows another's address. The station must see every robot, command each one alone, see
robots leave and a new one arrive.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import ExitStack, closing
from dataclasses import dataclass

import pytest

from interbot_core.topics import Lock, Topic
from interbot_link import RobotLink, StationLink, open_session
from interbot_link.router import open_router, router_config
from interbot_link.session import LinkConfigError
from robot_daemon.config import ConfigError, DaemonConfig, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.systemd_notify import SystemdNotifier

pytestmark = pytest.mark.timeout(120)


@dataclass
class Robot:
    robot_id: str
    daemon: Daemon
    stop: threading.Event
    thread: threading.Thread
    resources: ExitStack

    def shutdown(self) -> None:
        self.stop.set()
        self.thread.join(10.0)
        self.resources.close()


def start_robot(robot_id: str, router: str) -> Robot:
    config = DaemonConfig(
        robot_id=robot_id,
        sim=SimSettings(seed=1, people=0, realtime_factor=1.0),
        zenoh=ZenohSettings((), (router,), mode="client"),
        start_latched=False,  # a bare link, not a station: nobody would release the start latch
    )
    daemon = Daemon(config, DaemonOptions(auto_localise=True))
    resources = ExitStack()
    session = resources.enter_context(open_session([], [router], "client"))
    link = RobotLink(session, robot_id)
    resources.callback(link.close)
    stop = threading.Event()
    thread = threading.Thread(
        target=daemon.run, args=(link, stop, SystemdNotifier({})), daemon=True
    )
    thread.start()
    return Robot(robot_id, daemon, stop, thread, resources)


@pytest.fixture
def router(free_tcp_port: Callable[[], int]) -> Iterator[str]:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    session = open_router([endpoint])
    try:
        yield endpoint
    finally:
        session.close()


def test_five_robots_one_station_through_the_router(
    router: str, wait_until: Callable[..., None]
) -> None:
    robots = {f"bot{i}": start_robot(f"bot{i}", router) for i in range(5)}
    try:
        with (
            open_session([], [router], "client") as session,
            closing(StationLink(session)) as station,
        ):
            wait_until(lambda: set(robots) <= station.robots, 20.0, "all five robots")

            # Each robot is commanded alone: the stop reaches bot2 and no other.
            station.select_robot("bot2")

            def stopped(robot_id: str) -> bool:
                return "Emergency Stop" in robots[robot_id].daemon.stack.last_output.active_locks

            def send_stop() -> bool:
                station.send(Topic.STOP, Lock(True))
                return stopped("bot2")

            wait_until(send_stop, 10.0, "bot2's emergency stop")
            assert not any(stopped(r) for r in robots if r != "bot2")

            # Two robots leave, one new robot arrives.
            for gone in ("bot0", "bot4"):
                robots.pop(gone).shutdown()
            wait_until(lambda: not {"bot0", "bot4"} & station.robots, 10.0, "two robots gone")
            robots["bot5"] = start_robot("bot5", router)
            wait_until(lambda: "bot5" in station.robots, 10.0, "the new robot")
            assert station.robots == frozenset(robots)
    finally:
        for robot in robots.values():
            robot.shutdown()


def test_router_and_client_configs_refuse_nonsense() -> None:
    with pytest.raises(LinkConfigError):
        router_config([])
    with pytest.raises(LinkConfigError):
        router_config(["udp/224.0.0.224:7446"])
    with pytest.raises(ConfigError, match="client connects to a router"):
        ZenohSettings(("tcp/127.0.0.1:7447",), ("tcp/127.0.0.1:7448",), mode="client")
    with pytest.raises(ConfigError, match="mode"):
        ZenohSettings(mode="router")


def test_a_client_robot_waits_for_its_router(free_tcp_port: Callable[[], int]) -> None:
    """Started before the router, a client daemon waits (no session, no motion) and gives up
    cleanly when stopped."""
    from robot_daemon.daemon import _wait_for_router

    stop = threading.Event()
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    timer = threading.Timer(0.5, stop.set)
    timer.start()
    assert _wait_for_router((endpoint,), stop) is False
    session = open_router([endpoint])
    try:
        assert _wait_for_router((endpoint,), threading.Event()) is True
    finally:
        session.close()
