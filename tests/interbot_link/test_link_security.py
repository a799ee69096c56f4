"""Mutual TLS and access control on the zenoh link, attacked on 127.0.0.1 (issue 15).

One key directory per module (the CA, robot ``interbot1``, a station, an observer, a second
robot) and a second, foreign CA. A robot listens on ``tls/127.0.0.1:PORT``; legitimate and rogue
peers connect and publish on every command topic.
"""

from __future__ import annotations

import datetime as dt
import json
import threading
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
    LinkConfigError,
    LinkOpenError,
    LinkSecurity,
    RobotLink,
    StationLink,
    open_session,
    session_config,
)
from tests.interbot_link.attack import attack

pytestmark = pytest.mark.timeout(30)

ROBOT = "interbot1"


def wait_until(predicate: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    pause = threading.Event()
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"condition not met within {timeout} s")
        pause.wait(0.005)


@pytest.fixture(scope="module")
def keys(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("keys") / "interbot"
    store = KeyStore.init(directory)
    store.add("interbot2", "robot")
    store.add("station2", "station")
    store.revoke("station2")
    long_ago = dt.datetime.now(dt.UTC) - dt.timedelta(days=30)
    store.add("old_station", "station", now=long_ago, days=1)  # expired 29 days ago
    return directory


@pytest.fixture(scope="module")
def foreign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Another CA with members of the same names (a rogue who ran `interbot keys init`)."""
    directory = tmp_path_factory.mktemp("foreign") / "keys"
    KeyStore.init(directory)
    return directory


def _open_robot(stack: ExitStack, keys: Path, free_port: Callable[[], int], name: str = ROBOT):
    security = LinkSecurity.load(keys, name, "robot")
    for attempt in range(2):
        endpoint = f"tls/127.0.0.1:{free_port()}"
        try:
            session = stack.enter_context(open_session([endpoint], [], security=security))
            return endpoint, session
        except LinkOpenError:
            if attempt:
                raise
    raise AssertionError("unreachable")


@pytest.fixture
def robot(keys: Path, free_tcp_port: Callable[[], int]) -> Iterator[tuple[str, RobotLink]]:
    with ExitStack() as stack:
        endpoint, session = _open_robot(stack, keys, free_tcp_port)
        link = RobotLink(session, ROBOT)
        stack.callback(link.close)
        yield endpoint, link


def _raw_tls_config(directory: Path, name: str, endpoint: str) -> zenoh.Config:
    """A hand-made client config, as an attacker would write it (no ACL of ours)."""
    tls = {
        "root_ca_certificate": str(directory / "ca.crt"),
        "connect_certificate": str(directory / f"{name}.crt"),
        "connect_private_key": str(directory / f"{name}.key"),
        "enable_mtls": True,
        "verify_name_on_connect": False,
    }
    config = {
        "mode": "peer",
        "listen": {"endpoints": []},
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


# --------------------------------------------------------------------------- configuration


def test_plaintext_off_loopback_is_refused_with_instructions() -> None:
    with pytest.raises(InsecureEndpointError, match="interbot keys init"):
        session_config(["tcp/0.0.0.0:7447"], [])
    with pytest.raises(InsecureEndpointError, match="--insecure"):
        session_config([], ["tcp/192.168.1.20:7447"])
    with pytest.raises(InsecureEndpointError):
        session_config([], ["tcp/robot.example.org:7447"])
    assert session_config(["tcp/0.0.0.0:7447"], [], insecure=True) is not None
    assert session_config([], ["tcp/localhost:7447", "tcp/[::1]:7448"]) is not None


def test_tls_needs_keys_and_keys_need_tls(keys: Path) -> None:
    with pytest.raises(LinkConfigError, match="need keys"):
        session_config([], ["tls/127.0.0.1:7447"])
    security = LinkSecurity.load(keys, "station", "station")
    with pytest.raises(LinkConfigError, match="must be tls"):
        session_config([], ["tcp/127.0.0.1:7447"], security=security)
    config = session_config([], ["tls/192.168.1.20:7447"], security=security)
    assert json.loads(config.get_json("access_control/default_permission")) == "deny"
    assert json.loads(config.get_json("transport/link/tls/enable_mtls")) is True


def test_access_control_lists_only_unrevoked_members(keys: Path) -> None:
    acl = LinkSecurity.load(keys, ROBOT, "robot").access_control()
    subjects = {s["id"]: s["cert_common_names"] for s in acl["subjects"]}
    assert subjects == {"stations": ["station"], "observers": ["observer"]}
    puts = [r for r in acl["rules"] if r["flows"] == ["ingress"] and "put" in r["messages"]]
    assert [r["id"] for r in puts] == ["commands_in"]
    assert all(k.startswith(f"interbot/{ROBOT}/") for r in acl["rules"] for k in r["key_exprs"]
               if r["flows"] == ["egress"])  # fmt: skip


# --------------------------------------------------------------------------- the secure link


def test_station_commands_and_sees_state_over_mutual_tls(
    keys: Path, robot: tuple[str, RobotLink], query_state: Callable[..., dict[Topic, object]]
) -> None:
    endpoint, link = robot
    security = LinkSecurity.load(keys, "station", "station")
    with (
        open_session([], [endpoint], security=security) as session,
        closing(StationLink(session)) as st,
    ):
        wait_until(lambda: ROBOT in st.robots)
        st.select_robot(ROBOT)
        wait_until(lambda: link.subscribed(Topic.POSE))
        wait_until(lambda: st.send(Topic.STOP, Lock(True)))
        link.wait_commands(10.0)
        assert [c.topic for c in link.poll_commands()][:1] == [Topic.STOP]

        def pose_seen() -> bool:  # a DROP stream: published until it arrives, as a daemon does
            link.publish(Topic.POSE, PoseMsg(1.0, 2.0, 0.5))
            return isinstance(st.poll_state().get(Topic.POSE), PoseMsg)

        wait_until(pose_seen)
        assert Topic.POSE in query_state(st, ROBOT)


@pytest.mark.parametrize(
    "attacker", ["station", "observer", "revoked station", "other robot", "expired station"]
)
def test_members_without_command_rights_cannot_command(
    keys: Path, robot: tuple[str, RobotLink], attacker: str
) -> None:
    endpoint, link = robot
    name = {
        "observer": "observer",
        "revoked station": "station2",
        "other robot": "interbot2",
        "expired station": "old_station",
    }
    with zenoh.open(_raw_tls_config(keys, name.get(attacker, attacker), endpoint)) as session:
        time.sleep(0.3)  # let the link and declarations settle
        control = frozenset(str(t) for t in COMMAND_TOPICS) if attacker == "station" else None
        received = _attack(session, link, until=control or frozenset())
    if attacker == "station":  # the control: the same attack with command rights gets through
        assert received == {str(t) for t in COMMAND_TOPICS}
    else:
        assert received == set()


def test_observer_may_watch_and_query_but_not_command(
    keys: Path, robot: tuple[str, RobotLink], query_state: Callable[..., dict[Topic, object]]
) -> None:
    endpoint, link = robot
    security = LinkSecurity.load(keys, "observer", "observer")
    with (
        open_session([], [endpoint], security=security) as session,
        closing(StationLink(session)) as obs,
    ):
        wait_until(lambda: ROBOT in obs.robots)
        obs.select_robot(ROBOT)
        wait_until(lambda: link.subscribed(Topic.POSE))
        wait_until(  # the pose is a DROP stream: published until it arrives, as a daemon does
            lambda: (
                link.publish(Topic.POSE, PoseMsg(1.0, 2.0, 0.5)),
                isinstance(obs.poll_state().get(Topic.POSE), PoseMsg),
            )[1]
        )
        assert Topic.POSE in query_state(obs, ROBOT)
        assert _attack(session, link) == set()


@pytest.mark.parametrize("rogue", ["no certificate", "foreign CA", "plain tcp"])
def test_rogue_peers_get_no_link(
    keys: Path, foreign: Path, robot: tuple[str, RobotLink], rogue: str
) -> None:
    endpoint, link = robot
    if rogue == "foreign CA":
        config = _raw_tls_config(foreign, "station", endpoint)
    else:
        config = _raw_tls_config(keys, "station", endpoint)
        config.insert_json5("transport/link/tls/connect_certificate", "null")
        config.insert_json5("transport/link/tls/connect_private_key", "null")
        if rogue == "plain tcp":
            config.insert_json5("connect/endpoints", json.dumps([endpoint.replace("tls", "tcp")]))
    with zenoh.open(config) as session:
        time.sleep(0.3)
        assert not list(session.liveliness().get("interbot/*/alive", timeout=0.3))
        assert _attack(session, link) == set()


def test_a_robot_cannot_speak_for_another(keys: Path, free_tcp_port: Callable[[], int]) -> None:
    """interbot2 listens where the station expects interbot1 and publishes interbot1's pose."""
    with ExitStack() as stack:
        endpoint, impostor = _open_robot(stack, keys, free_tcp_port, "interbot2")
        security = LinkSecurity.load(keys, "station", "station")
        station_session = stack.enter_context(open_session([], [endpoint], security=security))
        station = StationLink(station_session)
        stack.callback(station.close)
        fake = impostor.declare_publisher(key(ROBOT, Topic.POSE))
        token = impostor.liveliness().declare_token(f"interbot/{ROBOT}/alive")
        stack.callback(token.undeclare)
        station.select_robot(ROBOT)
        time.sleep(0.3)
        for _ in range(5):
            fake.put(b"{}")
        time.sleep(0.2)
        assert station.robots == frozenset()
        assert station.poll_state() == {} and station.decode_errors == {}
