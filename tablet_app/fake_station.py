"""An in-process stand-in for the Base Station's tablet server, for tests and screenshots.

A `QTcpServer` on 127.0.0.1 (port chosen by the OS) that accepts tablets, records every JSON
object they send (decoded with `JsonStreamDecoder`, in arrival order), answers their pings
unless told not to, and sends whatever messages or raw bytes the caller asks for. It does no
robot logic: it is the far end of the wire and nothing more.
"""

from __future__ import annotations

import logging
from typing import Any

from PySide6.QtCore import QObject, Signal
from PySide6.QtNetwork import QHostAddress, QTcpServer, QTcpSocket

from interbot_core.protocol import JsonStreamDecoder, Message, Pong, encode

logger = logging.getLogger(__name__)


class FakeStation(QObject):
    """Records what tablets send; ``send``/``send_raw`` go to the newest client."""

    client_connected = Signal()
    object_received = Signal(object)

    def __init__(self, parent: QObject | None = None, answer_pings: bool = True) -> None:
        super().__init__(parent)
        self.answer_pings = answer_pings
        self.received: list[dict[str, Any]] = []
        self.raw = bytearray()
        self._server = QTcpServer(self)
        self._server.newConnection.connect(self._on_new_connection)
        self._client: QTcpSocket | None = None
        self._decoder = JsonStreamDecoder()
        self.clients_seen = 0

    def listen(self, port: int = 0) -> int:
        if not self._server.listen(QHostAddress(QHostAddress.SpecialAddress.LocalHost), port):
            raise OSError(f"fake station cannot listen: {self._server.errorString()}")
        return self.port

    @property
    def port(self) -> int:
        return int(self._server.serverPort())

    @property
    def has_client(self) -> bool:
        return (
            self._client is not None
            and self._client.state() == QTcpSocket.SocketState.ConnectedState
        )

    def close(self) -> None:
        """Stop listening and drop the client (the tablet sees a disconnect)."""
        self._server.close()
        if self._client is not None:
            self._client.abort()
            self._client.deleteLater()
            self._client = None

    def drop_client(self) -> None:
        if self._client is not None:
            self._client.disconnectFromHost()

    def send(self, msg: Message) -> None:
        self.send_raw(encode(msg))

    def send_raw(self, data: bytes) -> None:
        if self._client is None:
            raise RuntimeError("no tablet is connected to the fake station")
        self._client.write(data)
        self._client.flush()

    def messages(self, key: str) -> list[Any]:
        """Bodies of every received message with top-level ``key``, in order."""
        return [obj[key] for obj in self.received if key in obj]

    def clear(self) -> None:
        self.received.clear()
        self.raw.clear()

    def _on_new_connection(self) -> None:
        while self._server.hasPendingConnections():
            socket = self._server.nextPendingConnection()
            if self._client is not None:
                self._client.abort()
                self._client.deleteLater()
            self._client = socket
            self._decoder.reset()
            self.clients_seen += 1
            socket.readyRead.connect(self._on_ready_read)
            self.client_connected.emit()

    def _on_ready_read(self) -> None:
        if self._client is None:
            return
        data = bytes(self._client.readAll().data())
        self.raw += data
        for item in self._decoder.feed(data):
            if not isinstance(item, dict):
                logger.warning("fake station got a bad frame: %s", item)
                continue
            self.received.append(item)
            if self.answer_pings and "ping" in item:
                self.send_raw(encode_pong(item["ping"]))
            self.object_received.emit(item)


def encode_pong(ping_body: dict[str, Any]) -> bytes:
    return encode(Pong(int(ping_body["seq"]), float(ping_body["t"])))
