"""A building's router with mutual TLS and access control (issue 15): robots and stations as its
clients, attacked through it. The router enforces the robot and station rules in the middle."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, closing
from pathlib import Path

import pytest
import zenoh

from interbot_core.topics import COMMAND_TOPICS, Lock, PoseMsg, Topic, key
from interbot_link import (
    InsecureEndpointError,
    KeyStore,
    LinkSecurity,
    RobotLink,
    StationLink,
    open_session,
)
from interbot_link.router import open_router, router_config
from tests.interbot_link.attack import attack

pytestmark = pytest.mark.timeout(60)

ROBOT = "interbot1"


def wait_until(predicate: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"condition not met within {timeout} s")
        time.sleep(0.005)


@pytest.fixture(scope="module")
def keys(tmp_path_factory: pytest.TempPathFactory) -> Path:
    store = KeyStore.init(tmp_path_factory.mktemp("k") / "keys")
    store.add("router", "router")
    store.add("interbot2", "robot")
    return store.dir


@pytest.fixture
def building(keys: Path, free_tcp_port: Callable[[], int]) -> Iterator[tuple[str, RobotLink]]:
    with ExitStack() as stack:
        endpoint = f"tls/127.0.0.1:{free_tcp_port()}"
        router = open_router([endpoint], security=LinkSecurity.load(keys, "router", "router"))
        stack.callback(router.close)
        robot_sec = LinkSecurity.load(keys, ROBOT, "robot")
        session = stack.enter_context(open_session([], [endpoint], "client", security=robot_sec))
        link = RobotLink(session, ROBOT)
        stack.callback(link.close)
        yield endpoint, link


def _client(directory: Path, name: str, endpoint: str) -> zenoh.Config:
    tls = {
        "root_ca_certificate": str(directory / "ca.crt"),
        "connect_certificate": str(directory / f"{name}.crt"),
        "connect_private_key": str(directory / f"{name}.key"),
        "enable_mtls": True,
        "verify_name_on_connect": False,
    }
    config = {
        "mode": "client",
        "connect": {"endpoints": [endpoint]},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "transport": {"link": {"tls": tls}},
    }
    return zenoh.Config.from_json5(json.dumps(config))


def _attack(
    session: zenoh.Session, robot: RobotLink, until: frozenset[str] = frozenset()
) -> set[str]:
    """`attack` on this module's robot."""
    return attack(session, robot, ROBOT, until)


def test_a_plaintext_router_off_loopback_is_refused() -> None:
    with pytest.raises(InsecureEndpointError, match="interbot keys init"):
        router_config(["tcp/0.0.0.0:7447"])
    assert router_config(["tcp/0.0.0.0:7447"], insecure=True) is not None


def test_station_commands_and_watches_through_the_secure_router(
    keys: Path, building: tuple[str, RobotLink], query_state: Callable[..., dict[Topic, object]]
) -> None:
    endpoint, link = building
    security = LinkSecurity.load(keys, "station", "station")
    with (
        open_session([], [endpoint], "client", security=security) as session,
        closing(StationLink(session)) as station,
    ):
        wait_until(lambda: ROBOT in station.robots)
        station.select_robot(ROBOT)
        wait_until(lambda: link.subscribed(Topic.POSE))
        wait_until(lambda: station.send(Topic.STOP, Lock(True)))
        link.wait_commands(10.0)
        assert Topic.STOP in {c.topic for c in link.poll_commands()}
        wait_until(  # the pose is a DROP stream: published until it arrives, as a daemon does
            lambda: (
                link.publish(Topic.POSE, PoseMsg(1.0, 2.0, 0.5)),
                isinstance(station.poll_state().get(Topic.POSE), PoseMsg),
            )[1]
        )
        assert Topic.POSE in query_state(station, ROBOT)


@pytest.mark.parametrize("who", ["station", "observer", "interbot2"])
def test_through_the_router_only_stations_command(
    keys: Path, building: tuple[str, RobotLink], who: str
) -> None:
    endpoint, link = building
    with zenoh.open(_client(keys, who, endpoint)) as session:
        time.sleep(0.3)
        control = frozenset(str(t) for t in COMMAND_TOPICS) if who == "station" else frozenset()
        received = _attack(session, link, until=control)
    if who == "station":  # the control: the same attack with command rights gets through
        assert received == {str(t) for t in COMMAND_TOPICS}
    else:
        assert received == set()


def test_through_the_router_a_robot_cannot_speak_for_another(
    keys: Path, building: tuple[str, RobotLink]
) -> None:
    endpoint, _link = building
    security = LinkSecurity.load(keys, "station", "station")
    with (
        open_session([], [endpoint], "client", security=security) as session,
        closing(StationLink(session)) as station,
        zenoh.open(_client(keys, "interbot2", endpoint)) as impostor,
    ):
        wait_until(lambda: ROBOT in station.robots)
        station.select_robot(ROBOT)
        time.sleep(0.3)
        for _ in range(5):
            impostor.put(key(ROBOT, Topic.POSE), b'{"x": 9.0, "y": 9.0, "yaw": 0.0}')
        time.sleep(0.3)
        assert station.poll_state() == {} and station.decode_errors == {}
