"""JSON messages over one `QTcpSocket` (thesis §5.3.1-5.3.2; docs/protocol.md).

The thesis's Tablet and Base Station both read "every new cluster of data" from the socket on
``readyRead`` and parse it as JSON. `QtTcpConnection` does that with the protocol's pure pieces:
`interbot_core.protocol.JsonStreamDecoder` splits the byte stream into objects however TCP cut
it, and `interbot_core.protocol.encode` frames each outgoing message, which is written with ONE
``write()`` call on a socket with ``LowDelayOption`` (TCP_NODELAY) set, so no message waits for
Nagle + delayed ACK (FIELD_NOTES: 40-45 ms per message otherwise).

Bounded work (issue 11): with ``max_read_bytes`` set, one event-loop turn reads and decodes at
most that many bytes and schedules the rest for the next turn (so timers and clicks interleave
with a flood), and Qt's own read buffer is bounded too, so a sender that outpaces us is held
back by TCP rather than by our memory. ``batch_finished`` follows the objects of each turn.

It is direction-agnostic: it emits decoded JSON objects (dicts) and leaves validation to the
owner (`decode_station_message` on the Tablet, `decode_tablet_message` on the Base Station).
It can create its own client socket (`connect_to_host`) or adopt one accepted by a
`QTcpServer`.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtNetwork import QAbstractSocket, QTcpSocket

from interbot_core.protocol import (
    DEFAULT_MAX_FRAME_BYTES,
    JsonStreamDecoder,
    Message,
    ProtocolError,
    encode,
)

logger = logging.getLogger(__name__)


class QtTcpConnection(QObject):
    """Owns a `QTcpSocket`; sends `Message`s and emits each received JSON object.

    Signals: ``object_received(dict)``, ``frame_error(ProtocolError)`` (bytes that are not a
    valid frame), ``connected()``, ``disconnected()``, ``socket_error(str)``.
    """

    object_received = Signal(object)
    batch_finished = Signal()  # after the objects of one read (one event-loop turn)
    frame_error = Signal(object)
    connected = Signal()
    disconnected = Signal()
    socket_error = Signal(str)

    def __init__(
        self,
        socket: QTcpSocket | None = None,
        parent: QObject | None = None,
        max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES,
        max_read_bytes: int | None = None,
    ) -> None:
        super().__init__(parent)
        self._max_frame_bytes = max_frame_bytes
        self._max_read_bytes = max_read_bytes
        self._read_scheduled = False
        self._decoder = JsonStreamDecoder(max_frame_bytes)
        self.socket = socket if socket is not None else QTcpSocket()
        self.socket.setParent(self)
        self.socket.connected.connect(self._on_connected)
        self.socket.disconnected.connect(self.disconnected)
        self.socket.readyRead.connect(self._on_ready_read)
        self.socket.errorOccurred.connect(self._on_error)
        if max_read_bytes is not None:
            self.socket.setReadBufferSize(max(4 * max_read_bytes, max_frame_bytes))
        if self.is_connected:
            self._set_low_delay()

    @property
    def is_connected(self) -> bool:
        return self.socket.state() == QAbstractSocket.SocketState.ConnectedState

    def connect_to_host(self, host: str, port: int) -> None:
        """Start connecting (asynchronous: wait for ``connected`` or ``socket_error``)."""
        self._decoder.reset()
        self.socket.connectToHost(host, port)

    def abort(self) -> None:
        """Drop the connection at once (no ``disconnected`` if it was not connected)."""
        self.socket.abort()

    def close(self) -> None:
        """Flush what is queued, then close."""
        self.socket.disconnectFromHost()

    def send(self, msg: Message) -> bool:
        """Encode ``msg`` and write it in one call; False when not connected or short write."""
        return self.send_bytes(encode(msg, self._max_frame_bytes))

    def send_bytes(self, data: bytes) -> bool:
        """Write already framed bytes in one call (tests, compatibility clients)."""
        if not self.is_connected:
            logger.debug("not connected; dropped %d bytes", len(data))
            return False
        written = self.socket.write(data)
        if written != len(data):
            logger.warning("socket write returned %s for %d bytes", written, len(data))
            return False
        return True

    # ---------------------------------------------------------------- slots
    def _set_low_delay(self) -> None:
        self.socket.setSocketOption(QAbstractSocket.SocketOption.LowDelayOption, 1)

    def _on_connected(self) -> None:
        self._set_low_delay()
        self._decoder.reset()
        self.connected.emit()

    def _on_ready_read(self) -> None:
        self._read_scheduled = False
        if self._max_read_bytes is None:
            data = bytes(self.socket.readAll().data())
        else:
            data = bytes(self.socket.read(self._max_read_bytes).data())
            if self.socket.bytesAvailable() > 0 and not self._read_scheduled:
                self._read_scheduled = True  # the rest next turn: let timers and clicks run
                QTimer.singleShot(0, self, self._on_ready_read)
        for item in self._decoder.feed(data):
            if isinstance(item, ProtocolError):
                logger.warning("bad frame from %s: %s", self._peer(), item.message)
                self.frame_error.emit(item)
            else:
                self.object_received.emit(item)
        self.batch_finished.emit()

    def _on_error(self, error: QAbstractSocket.SocketError) -> None:
        if error == QAbstractSocket.SocketError.RemoteHostClosedError:
            return  # an orderly close: `disconnected` reports it
        self.socket_error.emit(self.socket.errorString())

    def _peer(self) -> str:
        return f"{self.socket.peerAddress().toString()}:{self.socket.peerPort()}"
