"""A rogue zenoh peer against the real daemon loop behind mutual TLS + access control (issue 15).

The daemon runs in a thread on simulated time, its link on ``tls/127.0.0.1:PORT`` with the
module's keys. The operator's station engages the emergency stop; then peers without command
rights (no certificate, a foreign CA, an observer certificate) send a valid message on every
command topic, ``stop_release`` first, many times: the robot never moves, the stop stays latched,
nothing else changes. Finally the operator's own station releases the stop and drives, which
shows the link was up all along.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest
import zenoh

from interbot_core.topics import (
    ConfigMsg,
    GoalMsg,
    InitialPose,
    Lock,
    RouteCancel,
    RouteMsg,
    StopRelease,
    Topic,
    Twist,
    encode,
    key,
)
from interbot_link import KeyStore, LinkSecurity, RobotLink, StationLink, open_session
from robot_daemon.config import DaemonConfig, SecuritySettings, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.link_security import link_security
from robot_daemon.systemd_notify import SystemdNotifier

ROBOT = "secbot"
pytestmark = pytest.mark.timeout(90)

ATTACK: list[tuple[Topic, object]] = [
    (Topic.STOP_RELEASE, StopRelease("mallory")),
    (Topic.STOP, Lock(False)),
    (Topic.PAUSE_NAV, Lock(False)),
    (Topic.STATION_VEL, Twist(1.0, 0.5)),
    (Topic.TABLET_VEL, Twist(1.0, -0.5)),
    (Topic.INITIAL_POSE, InitialPose(1.0, 1.0, 0.0)),
    (Topic.GOAL, GoalMsg(2.0, 2.0, 0.0)),
    (Topic.ROUTE, RouteMsg(99, ((2.0, 2.0, 0.0),))),
    (Topic.ROUTE_CANCEL, RouteCancel(None, "mallory")),
    (Topic.CONFIG, ConfigMsg({"max_linear_speed": 1.5})),
]


def _client_config(directory: Path, name: str | None, endpoint: str) -> zenoh.Config:
    """An attacker's own session (no access control of ours); ``name`` None: no certificate."""
    tls: dict[str, object] = {"root_ca_certificate": str(directory / "ca.crt")}
    if name is not None:
        tls |= {
            "connect_certificate": str(directory / f"{name}.crt"),
            "connect_private_key": str(directory / f"{name}.key"),
        }
    config = {
        "mode": "peer",
        "listen": {"endpoints": []},
        "connect": {"endpoints": [endpoint]},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "transport": {
            "link": {"tls": {**tls, "enable_mtls": True, "verify_name_on_connect": False}}
        },
    }
    return zenoh.Config.from_json5(json.dumps(config))


def _keys(root: Path) -> Path:
    members = ((ROBOT, "robot"), ("station", "station"), ("observer", "observer"))
    return KeyStore.init(root, members).dir


@pytest.fixture(scope="module")
def keys(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _keys(tmp_path_factory.mktemp("k") / "keys")


@pytest.fixture(scope="module")
def foreign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _keys(tmp_path_factory.mktemp("f") / "keys")


class SecureRig:
    def __init__(self, stack: ExitStack, keys: Path, endpoint: str) -> None:
        self.endpoint = endpoint
        config = DaemonConfig(
            robot_id=ROBOT,
            sim=SimSettings(seed=3, people=0, odometry="calibrated", realtime_factor=4.0),
            zenoh=ZenohSettings((endpoint,), ()),
            security=SecuritySettings(str(keys)),
            start_latched=False,  # a bare link, not a station: nobody would release the latch
        )
        security, insecure = link_security(config)
        assert security is not None and not insecure
        self.daemon = Daemon(config, DaemonOptions(auto_localise=True))
        session = stack.enter_context(open_session([endpoint], [], security=security))
        link = RobotLink(session, ROBOT)
        stack.callback(link.close)
        self.stop = threading.Event()
        thread = threading.Thread(
            target=self.daemon.run, args=(link, self.stop, SystemdNotifier({})), daemon=True
        )
        thread.start()
        stack.callback(thread.join, 10.0)
        stack.callback(self.stop.set)
        station_security = LinkSecurity.load(keys, "station", "station")
        station_session = stack.enter_context(
            open_session([], [endpoint], security=station_security)
        )
        self.station = StationLink(station_session)
        stack.callback(self.station.close)


@pytest.fixture(scope="module")
def rig(keys: Path) -> Iterator[SecureRig]:
    from tests.conftest import _free_tcp_port

    with ExitStack() as stack:
        yield SecureRig(stack, keys, f"tls/127.0.0.1:{_free_tcp_port()}")


def _moving(rig: SecureRig) -> bool:
    out = rig.daemon.stack.last_output
    return out.linear != 0.0 or out.angular != 0.0


def test_rogue_peers_never_move_the_robot_nor_release_the_stop(
    rig: SecureRig, keys: Path, foreign: Path, wait_until: Callable[..., None]
) -> None:
    station = rig.station
    wait_until(lambda: ROBOT in station.robots, 20.0, "the robot over mutual TLS")
    station.select_robot(ROBOT)

    def driving() -> bool:
        # The robot starts latched (issue 11): the operator's station releases it, as a real
        # station does on connecting, then drives.
        station.send(Topic.STOP, Lock(False))
        station.send(Topic.STOP_RELEASE, StopRelease("operator"))
        station.send(Topic.STATION_VEL, Twist(0.2, 0.0))
        return rig.daemon.stack.last_output.source == "Base Station"

    wait_until(driving, 20.0, "the operator's station to drive")
    station.send(Topic.STOP, Lock(True))
    wait_until(lambda: not _moving(rig), 5.0, "the emergency stop")

    attackers = {
        "no certificate": _client_config(keys, None, rig.endpoint),
        "foreign CA": _client_config(foreign, "station", rig.endpoint),
        "observer": _client_config(keys, "observer", rig.endpoint),
    }
    for who, config in attackers.items():
        with zenoh.open(config) as session:
            time.sleep(0.3)
            for _ in range(10):
                for topic, message in ATTACK:
                    session.put(key(ROBOT, topic), encode(topic, message))
                time.sleep(0.03)
                out = rig.daemon.stack.last_output
                assert not _moving(rig), f"{who} moved the robot: {out}"
                assert "Emergency Stop" in out.active_locks, f"{who} released the stop"
    assert rig.daemon.stack.route is None or rig.daemon.stack.route.route_id != 99

    station.send(Topic.STOP, Lock(False))  # the operator's own release: intent off, then release
    station.send(Topic.STOP_RELEASE, StopRelease("operator"))
    wait_until(driving, 20.0, "the operator to drive again after releasing the stop")


def test_robot_yaml_security_section_and_the_deploy_example(repo_root: Path) -> None:
    from robot_daemon.config import ConfigError, load_config, parse_config

    cfg = parse_config({"security": {"keys": "k", "insecure": False}}, "robot.yaml", Path("/x"))
    assert cfg.security == SecuritySettings("/x/k", False)
    with pytest.raises(
        ConfigError, match=r"unknown key 'security.key' \(allowed: keys, insecure\)"
    ):
        parse_config({"security": {"key": "k"}}, "robot.yaml", Path("/x"))
    deploy = load_config(repo_root / "deploy" / "robot.yaml")
    assert deploy.security.keys == "/etc/interbot/keys" and not deploy.security.insecure
    assert all(e.startswith("tls/") for e in deploy.zenoh.listen)


def test_daemon_refuses_plaintext_off_loopback_unless_insecure(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from interbot_link import InsecureEndpointError

    wide = DaemonConfig(robot_id=ROBOT, zenoh=ZenohSettings(("tcp/0.0.0.0:7447",), ()))
    with pytest.raises(InsecureEndpointError, match="interbot keys init"):
        link_security(wide)
    insecure = DaemonConfig(
        robot_id=ROBOT,
        zenoh=ZenohSettings(("tcp/0.0.0.0:7447",), ()),
        security=SecuritySettings(None, insecure=True),
    )
    assert link_security(insecure) == (None, True)
    assert "INSECURE" in caplog.text
