"""The tablet link behind TLS and pairing (issue 15), on 127.0.0.1 with real Qt sockets.

The station side is the real `TabletServer` listening through `TabletAuthServer`; the tablet is
the real `TabletConnection` over `PairedTlsConnection`. Rogue clients (plain TCP, TLS without a
token, a wrong code, a revoked token, a wrong pin) must be refused before any message reaches
`TabletServer.message_received`, i.e. before anything is acted on.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from PySide6.QtNetwork import QSslSocket, QTcpSocket

from base_station_app.tablet_auth import TabletAuthServer
from base_station_app.tablet_server import TabletServer
from interbot_core.protocol import Hello, Speed, encode
from interbot_core.tablet_pairing import TabletRegistry
from interbot_link import KeyStore
from tablet_app.pairing import PairedTlsConnection, TabletCredentials
from tablet_app.tablet_connection import TabletConnection

pytestmark = pytest.mark.timeout(60)

SPEED = b'{"speed": {"linear": 0.3, "angular": 0.0}}\n'


@pytest.fixture(scope="module")
def keys(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return KeyStore.init(tmp_path_factory.mktemp("k") / "keys").dir


class Station:
    def __init__(self, keys: Path, registry_path: Path) -> None:
        self.auth = TabletAuthServer.from_files(
            keys / "station.crt", keys / "station.key", registry_path, time.monotonic
        )
        self.server = TabletServer(time.monotonic, "127.0.0.1", 0, server=self.auth)
        self.received: list[object] = []
        self.refusals: list[str] = []
        self.server.message_received.connect(self.received.append)
        self.server.speed_received.connect(self.received.append)  # speeds: their own signal
        self.auth.auth_refused.connect(lambda _peer, why: self.refusals.append(why))
        assert self.server.listen()
        self.port = self.server.port


@pytest.fixture
def station(qtbot, keys: Path, tmp_path: Path):
    s = Station(keys, tmp_path / "tablets.json")
    yield s
    s.server.close()


def _tablet(qtbot, station: Station, **link_args) -> tuple[TabletConnection, PairedTlsConnection]:
    link = PairedTlsConnection(station.auth.fingerprint, **link_args)
    conn = TabletConnection("127.0.0.1", station.port, link=link)
    return conn, link


def _pair(qtbot, station: Station) -> TabletCredentials:
    code = station.auth.new_offer("127.0.0.1").code
    conn, link = _tablet(qtbot, station, pairing_code=code, name="lobby")
    creds: list[TabletCredentials] = []
    link.paired.connect(creds.append)
    with qtbot.waitSignal(conn.connected, timeout=5000):
        conn.start()
    qtbot.waitUntil(lambda: station.server.is_connected, timeout=10_000)
    assert conn.send(Speed(0.2, 0.0))
    qtbot.waitUntil(lambda: len(station.received) == 1, timeout=10_000)
    assert isinstance(station.received[0], Speed)
    conn.stop()
    qtbot.waitUntil(lambda: not station.server.is_connected, timeout=10_000)
    return creds[0]


def test_pairing_gives_a_token_that_reconnects_and_the_protocol_is_unchanged(
    qtbot, station: Station, tmp_path: Path
) -> None:
    creds = _pair(qtbot, station)
    assert creds.fingerprint == station.auth.fingerprint and len(creds.token) == 64
    creds.save(tmp_path / "tablet.json")
    again = TabletCredentials.load(tmp_path / "tablet.json")
    conn, _ = _tablet(qtbot, station, token=again.token)
    with qtbot.waitSignal(conn.robot_name_changed, timeout=5000):  # hello -> welcome in TLS
        conn.start()
    assert station.server.greeted
    conn.stop()
    saved = json.loads((tmp_path / "tablets.json").read_text())
    assert creds.token not in json.dumps(saved) and saved["tablets"][0]["name"] == "lobby"


def test_a_used_or_wrong_code_is_refused(qtbot, station: Station) -> None:
    offer = station.auth.new_offer("127.0.0.1")
    wrong = f"{(int(offer.code) + 1) % 10**6:06d}"
    conn, link = _tablet(qtbot, station, pairing_code=wrong)
    refusals: list[str] = []
    conn.refused.connect(refusals.append)
    with qtbot.waitSignal(link.auth_failed, timeout=5000) as blocker:
        conn.start()
    assert "wrong pairing code" in blocker.args[0]
    qtbot.waitUntil(lambda: refusals == ["wrong pairing code"])  # shown like any refusal
    conn.stop()
    assert station.received == [] and not station.server.is_connected


def test_revoked_tablet_is_refused_and_dropped_if_connected(qtbot, station: Station) -> None:
    creds = _pair(qtbot, station)
    conn, _link = _tablet(qtbot, station, token=creds.token)
    with qtbot.waitSignal(conn.connected, timeout=5000):
        conn.start()
    qtbot.waitUntil(lambda: station.server.is_connected, timeout=10_000)
    record = next(r for r in station.auth.registry.records if r.token_sha256)
    station.auth.revoke(record.tablet_id)
    qtbot.waitUntil(lambda: not station.server.is_connected, timeout=10_000)
    conn.stop()
    received = len(station.received)
    conn2, link2 = _tablet(qtbot, station, token=creds.token)
    with qtbot.waitSignal(link2.auth_failed, timeout=5000) as blocker:
        conn2.start()
    assert "revoked" in blocker.args[0]
    conn2.stop()
    assert len(station.received) == received


def test_a_wrong_pin_sends_nothing(qtbot, station: Station) -> None:
    link = PairedTlsConnection("00" * 32, token="ab" * 32)
    conn = TabletConnection("127.0.0.1", station.port, link=link)
    refusals: list[str] = []
    conn.refused.connect(refusals.append)
    with qtbot.waitSignal(link.auth_failed, timeout=5000) as blocker:
        conn.start()
    assert "is not the one this tablet was paired with" in blocker.args[0]
    qtbot.waitUntil(lambda: any("paired with" in r for r in refusals))  # on screen
    conn.stop()
    assert station.received == [] and not station.server.is_connected


def test_plain_tcp_client_is_refused_before_anything_is_acted_on(qtbot, station: Station) -> None:
    sock = QTcpSocket()
    sock.connectToHost("127.0.0.1", station.port)
    assert sock.waitForConnected(3000)
    sock.write(SPEED * 5 + encode(Hello(1, "rogue")))
    qtbot.waitUntil(lambda: bool(station.refusals), timeout=5000)
    assert "TLS handshake failed" in station.refusals[0]
    assert station.received == [] and not station.server.is_connected
    sock.abort()


def test_tls_client_without_token_is_refused_before_anything_is_acted_on(
    qtbot, station: Station
) -> None:
    sock = QSslSocket()
    sock.setPeerVerifyMode(QSslSocket.PeerVerifyMode.VerifyNone)
    sock.encrypted.connect(lambda: sock.write(SPEED))
    sock.connectToHostEncrypted("127.0.0.1", station.port)
    qtbot.waitUntil(lambda: bool(station.refusals), timeout=5000)
    assert "requires a paired tablet" in station.refusals[0]
    qtbot.waitUntil(lambda: sock.bytesAvailable() > 0 or not sock.isOpen(), timeout=10_000)
    assert b"refused" in bytes(sock.readAll().data())
    assert station.received == [] and not station.server.is_connected
    sock.abort()


def test_silent_tls_client_times_out(qtbot, keys: Path, tmp_path: Path) -> None:
    cert, key = (keys / "station.crt").read_bytes(), (keys / "station.key").read_bytes()
    registry = TabletRegistry(lambda n: b"\1" * n)
    auth = TabletAuthServer(cert, key, registry, time.monotonic, handshake_timeout_ms=200)
    server = TabletServer(time.monotonic, "127.0.0.1", 0, server=auth)
    refusals: list[str] = []
    auth.auth_refused.connect(lambda _p, why: refusals.append(why))
    assert server.listen()
    sock = QSslSocket()
    sock.setPeerVerifyMode(QSslSocket.PeerVerifyMode.VerifyNone)
    sock.connectToHostEncrypted("127.0.0.1", server.port)
    qtbot.waitUntil(lambda: bool(refusals), timeout=10_000)
    assert "within the time allowed" in refusals[0]
    sock.abort()
    server.close()


def test_a_flood_of_silent_clients_is_capped(qtbot, station: Station) -> None:
    from base_station_app.tablet_auth import MAX_PENDING, _PendingTablet

    sockets = [QTcpSocket() for _ in range(MAX_PENDING + 4)]
    for sock in sockets:
        sock.connectToHost("127.0.0.1", station.port)
    qtbot.waitUntil(
        lambda: all(s.state() != s.SocketState.ConnectingState for s in sockets), timeout=5000
    )
    qtbot.wait(200)
    assert len(station.auth.findChildren(_PendingTablet)) <= MAX_PENDING
    for sock in sockets:
        sock.abort()
