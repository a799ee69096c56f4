"""QtTcpConnection over real loopback sockets: one write per message, objects out of a stream."""

from __future__ import annotations

from typing import Any

import pytest
from PySide6.QtNetwork import QAbstractSocket, QHostAddress, QTcpServer, QTcpSocket

from interbot_core.protocol import Goal, InvalidJson, Speed
from interbot_qt.qt_tcp_connection import QtTcpConnection


@pytest.fixture
def pair(qtbot: Any) -> Any:
    server = QTcpServer()
    assert server.listen(QHostAddress(QHostAddress.SpecialAddress.LocalHost), 0)
    client = QtTcpConnection()
    with qtbot.waitSignal(client.connected):
        client.connect_to_host("127.0.0.1", server.serverPort())
    qtbot.waitUntil(server.hasPendingConnections)
    accepted = QtTcpConnection(server.nextPendingConnection())
    yield client, accepted
    client.abort()
    accepted.abort()
    server.close()


def test_low_delay_on_both_ends(pair: Any) -> None:
    client, accepted = pair
    for conn in (client, accepted):
        assert conn.socket.socketOption(QAbstractSocket.SocketOption.LowDelayOption) == 1


def test_messages_arrive_as_objects_in_order(qtbot: Any, pair: Any) -> None:
    client, accepted = pair
    got: list[Any] = []
    accepted.object_received.connect(got.append)
    assert client.send(Goal(7))
    assert client.send(Speed(0.25, -0.5))
    qtbot.waitUntil(lambda: len(got) == 2)
    assert got == [{"goal": 7}, {"speed": {"linear": 0.25, "angular": -0.5}}]


def test_each_message_is_one_write(qtbot: Any, pair: Any, monkeypatch: Any) -> None:
    client, _accepted = pair
    writes: list[bytes] = []
    original = QTcpSocket.write

    def spy(self: QTcpSocket, data: Any) -> int:
        writes.append(bytes(data))
        return original(self, data)

    monkeypatch.setattr(QTcpSocket, "write", spy)
    client.send(Speed(0.1, 0.2))
    assert writes == [b'{"speed":{"linear":0.1,"angular":0.2}}\n']


def test_garbage_is_a_frame_error_and_the_stream_continues(qtbot: Any, pair: Any) -> None:
    client, accepted = pair
    errors: list[Any] = []
    got: list[Any] = []
    accepted.frame_error.connect(errors.append)
    accepted.object_received.connect(got.append)
    client.send_bytes(b'oops {"goal":1}')
    qtbot.waitUntil(lambda: got == [{"goal": 1}])
    assert len(errors) == 1 and isinstance(errors[0], InvalidJson)


def test_send_without_connection_is_refused(qtbot: Any) -> None:
    conn = QtTcpConnection()
    assert conn.send(Goal(1)) is False
    assert not conn.is_connected
