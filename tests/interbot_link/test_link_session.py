"""session_config builds a closed-world zenoh configuration; open_session always closes."""

from __future__ import annotations

import json
import socket

import pytest

from interbot_link import LinkConfigError, LinkOpenError, open_session, session_config

pytestmark = pytest.mark.timeout(20)


def _get(config: object, key: str) -> object:
    return json.loads(config.get_json(key))  # type: ignore[attr-defined]


def test_config_has_no_scouting_and_exactly_the_given_endpoints() -> None:
    config = session_config(["tcp/127.0.0.1:7447"], ["tcp/127.0.0.1:7448"], lease_ms=2000)
    assert _get(config, "mode") == "peer"
    assert _get(config, "listen/endpoints") == ["tcp/127.0.0.1:7447"]
    assert _get(config, "connect/endpoints") == ["tcp/127.0.0.1:7448"]
    assert _get(config, "scouting/multicast/enabled") is False
    assert _get(config, "scouting/gossip/enabled") is False
    assert _get(config, "transport/link/tx/lease") == 2000
    assert _get(config, "transport/link/tx/keep_alive") == 4


def test_config_without_listen_endpoints_listens_nowhere() -> None:
    # zenoh's default for a peer is tcp/[::]:0 (every interface); ours is the empty list.
    config = session_config([], ["tcp/127.0.0.1:7447"])
    assert _get(config, "listen/endpoints") == []


@pytest.mark.parametrize(
    ("listen", "connect", "match"),
    [
        (["udp/224.0.0.224:7446"], [], "tcp/HOST:PORT"),
        (["tcp/224.0.0.224:7446"], [], "multicast"),
        ([], ["tcp/0.0.0.0:7447"], "cannot connect"),
        ([], ["tcp/127.0.0.1:0"], "port"),
        ([], ["tcp/127.0.0.1:70000"], "port"),
        ([], ["tcp/127.0.0.1"], "tcp/HOST:PORT"),
        ([], ["tls/127.0.0.1:7447"], "tcp/HOST:PORT"),
        ([], [], "at least one"),
    ],
)
def test_unsafe_or_malformed_endpoints_are_refused(
    listen: list[str], connect: list[str], match: str
) -> None:
    with pytest.raises(LinkConfigError, match=match):
        session_config(listen, connect)


def test_bad_mode_lease_and_string_endpoints_are_refused() -> None:
    with pytest.raises(LinkConfigError, match="mode"):
        session_config([], ["tcp/127.0.0.1:7447"], mode="router")
    with pytest.raises(LinkConfigError, match="lease_ms"):
        session_config([], ["tcp/127.0.0.1:7447"], lease_ms=100)
    with pytest.raises(LinkConfigError, match="lists"):
        session_config("tcp/127.0.0.1:7447", [])  # type: ignore[arg-type]
    with pytest.raises(LinkConfigError, match="client only connects"):
        session_config(["tcp/127.0.0.1:7447"], [], mode="client")


def test_hostnames_and_ipv6_are_accepted() -> None:
    config = session_config(["tcp/[::1]:7447"], ["tcp/robot-1.local:7447"], insecure=True)
    assert _get(config, "connect/endpoints") == ["tcp/robot-1.local:7447"]


def test_open_session_reports_a_taken_port_and_closes_on_error() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with (
            pytest.raises(LinkOpenError, match="Address already in use"),
            open_session([f"tcp/127.0.0.1:{port}"], []),
        ):
            pass
    with pytest.raises(RuntimeError, match="boom"), open_session(["tcp/127.0.0.1:0"], []) as s:
        held = s
        raise RuntimeError("boom")
    assert held.is_closed()
