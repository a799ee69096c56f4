"""The Base Station's TCP server for the Tablet (thesis §5.3.1, Fig. 5.8; docs/protocol.md).

As in the thesis, the station creates a `QTcpServer` at start-up and listens; ``newConnection``
accepts the tablet's socket (``nextPendingConnection``) and its ``readyRead`` feeds the JSON
decoder. Beyond the thesis:

* one controlling tablet at a time: a second connection gets ``{"refused": {"reason": ...}}``
  and is closed; after the tablet disconnects the next one is accepted (the server keeps
  listening throughout, which is the thesis's "restart the QTcpServer" without a gap);
* each message is validated (`decode_tablet_message`); a bad one is answered with
  ``{"error": ...}``, and the connection is closed after repeated errors or a frame that is too
  large (`ErrorBudget`);
* ``hello`` is answered with ``welcome`` (or ``refused`` for another protocol version); a
  client that sends no ``hello`` (the thesis's own) is served in compatibility mode;
* ``ping`` is answered with ``pong``, and the station pings the tablet every second: the round
  trip of each ``pong`` is the latency shown to the operator.

Framing and validation are the pure `interbot_core.protocol` functions; this object only moves
bytes (`interbot_qt.qt_tcp_connection.QtTcpConnection`: one write per message, TCP_NODELAY).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtNetwork import QAbstractSocket, QHostAddress, QTcpServer, QTcpSocket

from base_station_app.tablet_session import ErrorBudget
from interbot_core.protocol import (
    DEFAULT_LIMITS,
    PROTOCOL_VERSION,
    ErrorReport,
    FrameTooLarge,
    Hello,
    Message,
    Ping,
    Pong,
    ProtocolError,
    ProtocolLimits,
    Refused,
    Welcome,
    decode_tablet_message,
    encode,
)
from interbot_qt.qt_tcp_connection import QtTcpConnection

logger = logging.getLogger(__name__)


class TabletServer(QObject):
    """Listens for tablets and talks to the one that controls the robot.

    Signals: ``connected(peer: str)``, ``disconnected()``, ``message_received(msg)`` (validated
    tablet messages other than hello/ping/pong), ``latency_measured(rtt [s])``,
    ``protocol_error(text)``, ``refused(peer, reason)``.
    """

    connected = Signal(str)
    disconnected = Signal()
    message_received = Signal(object)
    latency_measured = Signal(float)
    protocol_error = Signal(str)
    refused = Signal(str, str)

    def __init__(
        self,
        clock: Callable[[], float],
        host: str = "127.0.0.1",
        port: int = 5555,
        *,
        robot_name: Callable[[], str] = lambda: "interbot",
        limits: ProtocolLimits = DEFAULT_LIMITS,
        ping_interval_ms: int = 1000,
        error_budget: ErrorBudget | None = None,
        server: QTcpServer | None = None,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self._clock = clock
        self._host = host
        self._port = port
        self._robot_name = robot_name
        self.limits = limits
        self._budget = error_budget if error_budget is not None else ErrorBudget()
        # ``server``: e.g. `tablet_auth.TabletAuthServer` (TLS + pairing, issue 15); its
        # sockets reach ``pendingConnectionAvailable`` only once authorised.
        self._server = server if server is not None else QTcpServer(self)
        self._server.setParent(self)
        self._server.pendingConnectionAvailable.connect(self._on_new_connection)
        self._conn: QtTcpConnection | None = None
        self._peer = ""
        self._greeted = False
        self._ping_seq = 0
        self._ping_timer = QTimer(self)
        self._ping_timer.setInterval(ping_interval_ms)
        self._ping_timer.timeout.connect(self.ping)

    # ------------------------------------------------------------------ state
    @property
    def port(self) -> int:
        return int(self._server.serverPort())

    @property
    def is_listening(self) -> bool:
        return self._server.isListening()

    @property
    def is_connected(self) -> bool:
        return self._conn is not None and self._conn.is_connected

    @property
    def peer(self) -> str:
        return self._peer

    @property
    def greeted(self) -> bool:
        """True once the tablet said hello (False: compatibility mode, or nobody connected)."""
        return self._greeted

    def listen(self) -> bool:
        address = QHostAddress(self._host)
        if not self._server.listen(address, self._port):
            logger.error(
                "cannot listen for the tablet on %s:%d: %s",
                self._host,
                self._port,
                self._server.errorString(),
            )
            return False
        logger.info("listening for the tablet on %s:%d", self._host, self.port)
        return True

    def close(self) -> None:
        """Stop listening and drop the tablet (shutdown)."""
        self._ping_timer.stop()
        self._server.close()
        if self._conn is not None:
            conn, self._conn = self._conn, None
            conn.abort()
            conn.deleteLater()

    def send(self, msg: Message) -> bool:
        """Send one message to the connected tablet; False when none is connected."""
        if self._conn is None:
            return False
        return self._conn.send(msg)

    def ping(self) -> None:
        if self.is_connected:
            self._ping_seq += 1
            self.send(Ping(self._ping_seq, self._clock()))

    def disconnect_tablet(self, reason: str = "") -> None:
        """Close the tablet's connection (after flushing what was written)."""
        if self._conn is not None:
            logger.info("closing the tablet connection %s: %s", self._peer, reason)
            self._conn.close()

    # ------------------------------------------------------------------ slots
    def _on_new_connection(self) -> None:
        while self._server.hasPendingConnections():
            socket = self._server.nextPendingConnection()
            if socket is None:  # pragma: no cover - Qt contract
                return
            peer = f"{socket.peerAddress().toString()}:{socket.peerPort()}"
            if self._conn is not None:
                self._refuse(socket, peer, f"another tablet ({self._peer}) is connected")
                continue
            self._accept(socket, peer)

    def _refuse(self, socket: QTcpSocket, peer: str, reason: str) -> None:
        logger.warning("refusing tablet %s: %s", peer, reason)
        socket.setSocketOption(QAbstractSocket.SocketOption.LowDelayOption, 1)
        socket.write(encode(Refused(reason)))
        socket.disconnected.connect(socket.deleteLater)
        socket.disconnectFromHost()
        self.refused.emit(peer, reason)

    def _accept(self, socket: QTcpSocket, peer: str) -> None:
        conn = QtTcpConnection(socket, parent=self)
        self._conn = conn
        self._peer = peer
        self._greeted = False
        self._budget.reset()
        conn.object_received.connect(self._on_object)
        conn.frame_error.connect(self._on_frame_error)
        conn.disconnected.connect(self._on_disconnected)
        self._ping_timer.start()
        logger.info("tablet connected from %s", peer)
        self.connected.emit(peer)

    def _on_disconnected(self) -> None:
        conn = self.sender()
        if conn is not self._conn or self._conn is None:
            return
        self._conn = None
        self._ping_timer.stop()
        conn.deleteLater()
        logger.info("tablet %s disconnected; waiting for the next one", self._peer)
        self._peer = ""
        self._greeted = False
        self.disconnected.emit()

    def _report(self, error: ProtocolError) -> None:
        self.send(ErrorReport.from_exception(error, self.limits))
        self.protocol_error.emit(f"{error.code}: {error.message}")
        fatal = isinstance(error, FrameTooLarge)
        if self._budget.record(self._clock(), fatal=fatal):
            why = "frame too large" if fatal else "repeated protocol errors"
            self.disconnect_tablet(why)

    def _on_frame_error(self, error: ProtocolError) -> None:
        self._report(error)

    def _on_object(self, obj: object) -> None:
        try:
            msg = decode_tablet_message(obj, self.limits)
        except ProtocolError as exc:
            self._report(exc)
            return
        if isinstance(msg, Hello):
            self._on_hello(msg)
        elif isinstance(msg, Pong):
            self.latency_measured.emit(max(0.0, msg.round_trip(self._clock())))
        elif isinstance(msg, Ping):
            self.send(msg.pong())
        elif isinstance(msg, ErrorReport):
            self.protocol_error.emit(f"tablet reports {msg.code}: {msg.message}")
        else:
            self.message_received.emit(msg)

    def _on_hello(self, hello: Hello) -> None:
        if hello.protocol != PROTOCOL_VERSION:
            reason = (
                f"protocol {hello.protocol} is not supported; this station speaks "
                f"protocol {PROTOCOL_VERSION}"
            )
            self.send(Refused(reason))
            self.refused.emit(self._peer, reason)
            self.disconnect_tablet(reason)
            return
        self._greeted = True
        self.send(Welcome(PROTOCOL_VERSION, self._robot_name()))
