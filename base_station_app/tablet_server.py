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

Bounded work and memory (issue 11), whatever one client sends:

* reads of at most ``MAX_READ_BYTES`` per event-loop turn (the rest next turn; Qt's read buffer
  is bounded, so a faster sender is held back by TCP), and `TabletInputPolicy` on every object:
  a per-turn cap and a per-second rate, the rest dropped with an error to the client (the
  ``stop`` always passes); the station's own e-stop button stays responsive under any input;
* of the speed commands of one turn only the newest is passed on (a burst after a stall is not
  replayed);
* a greeted tablet that answers no ``ping`` for ``pong_timeout_s`` is disconnected, and TCP
  keepalive (idle 5 s, 3 probes 2 s apart) frees the slot from a peer that vanished without a
  FIN; a client that does not read is disconnected once ``MAX_OUTPUT_BYTES`` are queued for it.

Framing and validation are the pure `interbot_core.protocol` functions; this object only moves
bytes (`interbot_qt.qt_tcp_connection.QtTcpConnection`: one write per message, TCP_NODELAY).

Its own thread (issue 14): `start_thread` moves the server, its sockets (TLS included) and
timers into a `QThread` with its own event loop, so reading the tablet never waits for the Qt
thread's drawing. Speed commands leave as ``speed_received`` in that thread (the station's
`TabletTeleop` forwards them from there); everything else reaches the station through queued
signals. The public methods (`send`, `listen`, `close`, `ping`, `disconnect_tablet`) may be
called from any thread: they run in the server's thread (`ThreadCall`) and return its answer.
That thread runs at real-time priority where the OS allows it (`priority` says;
`interbot_link.command_priority`): a speed command that arrives while the Qt thread draws, or
other programs keep the cores busy, is read and forwarded at once.

No ``QObject.sender()`` in this thread: each connection's slots are bound to that connection
(`functools.partial`). PySide calls ``sender()`` holding the GIL, and Qt's ``sender()`` locks
the object's signal-slot mutex (one of a pool of 131, chosen by address). A disconnect in the
Qt thread holds such a mutex while it calls the sender's ``disconnectNotify``, which PySide's
wrapper answers only after taking the GIL: each thread waited for the other's lock and the
whole station froze (seen in the 10th loop of the end-to-end task tests under load: the tablet
thread in ``_on_object``'s ``self.sender()``, the Qt thread in a pytest-qt wait's disconnect;
`tests/base_station_app/test_tablet_lock_order.py` holds that mutex on purpose).
"""

from __future__ import annotations

import logging
import socket as pysocket
from collections.abc import Callable
from functools import partial

from PySide6.QtCore import QCoreApplication, QObject, QThread, QTimer, Signal
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
    Speed,
    Welcome,
    decode_tablet_message,
    encode,
)
from interbot_core.tablet_input_policy import InputPolicyConfig, TabletInputPolicy
from interbot_link.command_priority import PriorityOutcome, raise_current_thread
from interbot_qt.qt_tcp_connection import QtTcpConnection
from interbot_qt.thread_call import ThreadCall

logger = logging.getLogger(__name__)

MAX_READ_BYTES = 2048  # per event-loop turn (~50 small messages: the per-turn cap)
MAX_OUTPUT_BYTES = 256 * 1024  # queued for a tablet that does not read: then it is dropped
KEEPALIVE = (5, 2, 3)  # TCP_KEEPIDLE [s], TCP_KEEPINTVL [s], TCP_KEEPCNT


def enable_keepalive(socket: QTcpSocket, idle_s: int, interval_s: int, count: int) -> None:
    """TCP keepalive with short timers (Linux), so a vanished peer frees its slot in seconds."""
    socket.setSocketOption(QAbstractSocket.SocketOption.KeepAliveOption, 1)
    fd = int(socket.socketDescriptor())
    if fd < 0 or not hasattr(pysocket, "TCP_KEEPIDLE"):
        return
    # fromfd() duplicates the descriptor: the options apply to the connection, and closing the
    # duplicate leaves Qt's descriptor open.
    with pysocket.fromfd(fd, pysocket.AF_INET, pysocket.SOCK_STREAM) as dup:
        try:
            dup.setsockopt(pysocket.IPPROTO_TCP, pysocket.TCP_KEEPIDLE, idle_s)
            dup.setsockopt(pysocket.IPPROTO_TCP, pysocket.TCP_KEEPINTVL, interval_s)
            dup.setsockopt(pysocket.IPPROTO_TCP, pysocket.TCP_KEEPCNT, count)
        except OSError as exc:  # pragma: no cover - platform without these options
            logger.warning("cannot tune TCP keepalive: %s", exc)


class TabletServer(QObject):
    """Listens for tablets and talks to the one that controls the robot.

    Signals: ``connected(peer: str)``, ``disconnected()``, ``message_received(msg)`` (validated
    tablet messages other than speed/hello/ping/pong), ``speed_received(Speed)`` (the newest
    speed of a read turn, emitted in the server's thread), ``latency_measured(rtt [s])``,
    ``protocol_error(text)``, ``refused(peer, reason)``.
    """

    connected = Signal(str)
    disconnected = Signal()
    message_received = Signal(object)
    speed_received = Signal(object)
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
        input_policy: InputPolicyConfig | None = None,
        pong_timeout_s: float | None = None,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self._clock = clock
        self._host = host
        self._robot_name = robot_name
        self.limits = limits
        self._budget = error_budget if error_budget is not None else ErrorBudget()
        # ``server``: e.g. `tablet_auth.TabletAuthServer` (TLS + pairing, issue 15); its
        # sockets reach ``pendingConnectionAvailable`` only once authorised.
        self._server = server if server is not None else QTcpServer(self)
        self._server.setParent(self)
        self._server.pendingConnectionAvailable.connect(self._on_new_connection)
        self._conn: QtTcpConnection | None = None
        self.peer = ""
        self.greeted = False  # the tablet said hello (False: compatibility mode, or nobody)
        self._ping_seq = 0
        self._ping_timer = QTimer(self)
        self._ping_timer.setInterval(ping_interval_ms)
        self._ping_timer.timeout.connect(self._ping_now)
        self.policy = TabletInputPolicy(input_policy)
        # [s] a greeted tablet silent to pings this long is gone (default: 5 pings, >= 3 s)
        self.pong_timeout_s = (
            pong_timeout_s if pong_timeout_s is not None else max(3.0, 5 * ping_interval_ms / 1000)
        )
        self._last_pong = 0.0
        self._newest_speed: Speed | None = None
        self._call = ThreadCall(self)  # public methods run in the server's thread
        self._thread: QThread | None = None
        self.port = port  # the port listened on, once listening (0: the OS picks)
        self.priority: PriorityOutcome | None = None  # its thread's scheduling (start_thread)

    # ------------------------------------------------------------------ its thread
    def start_thread(self) -> None:
        """Move the server (sockets, timers, children) into a thread with its own event loop."""
        if self._thread is not None or self.parent() is not None:
            return
        thread = QThread()
        thread.setObjectName("tablet")
        self.moveToThread(thread)
        thread.start()
        self._thread = thread
        self.priority = self._call.run(self._raise_priority)

    def _raise_priority(self) -> PriorityOutcome | None:
        """Real-time priority for the tablet thread (never for the thread that started it)."""
        if self._thread is None or QThread.currentThread() is not self._thread:
            return None
        return raise_current_thread("the tablet thread")

    def stop_thread(self) -> None:
        """Close, bring the server back to the application's thread and end its thread."""
        thread = self._thread
        if thread is None:
            self.close()
            return
        app = QCoreApplication.instance()

        def close_and_return() -> None:
            self._close_now()
            if app is not None:
                self.moveToThread(app.thread())

        self._call.run(close_and_return)
        thread.quit()
        thread.wait()
        self._thread = None

    # ------------------------------------------------------------------ state

    @property
    def is_connected(self) -> bool:
        return self._conn is not None and self._conn.is_connected

    def listen(self) -> bool:
        return bool(self._call.run(self._listen_now))

    def _listen_now(self) -> bool:
        address = QHostAddress(self._host)
        if not self._server.listen(address, self.port):
            logger.error(
                "cannot listen for the tablet on %s:%d: %s",
                self._host,
                self.port,
                self._server.errorString(),
            )
            return False
        self.port = int(self._server.serverPort())
        logger.info("listening for the tablet on %s:%d", self._host, self.port)
        return True

    def close(self) -> None:
        """Stop listening and drop the tablet (shutdown)."""
        self._call.run(self._close_now)

    def _close_now(self) -> None:
        self._ping_timer.stop()
        self._server.close()
        if self._conn is not None:
            conn, self._conn = self._conn, None
            conn.abort()
            conn.deleteLater()

    def send(self, msg: Message) -> bool:
        """Send one message to the connected tablet; False when none is connected."""
        return bool(self._call.run(lambda: self._send_now(msg)))

    def _send_now(self, msg: Message) -> bool:
        if self._conn is None:
            return False
        ok = self._conn.send(msg)
        if self._conn.socket.bytesToWrite() > MAX_OUTPUT_BYTES:
            self._drop_slow_reader()
            return False
        return ok

    def _drop_slow_reader(self) -> None:
        conn = self._conn
        if conn is None:
            return
        queued = conn.socket.bytesToWrite()
        logger.warning(
            "tablet %s does not read (%d bytes queued): disconnecting", self.peer, queued
        )
        self.protocol_error.emit(f"tablet does not read ({queued} bytes queued): disconnected")
        conn.abort()  # disconnected() follows and frees the slot

    def _ping_now(self) -> None:
        if not self.is_connected:
            return
        now = self._clock()
        if self.greeted and now - self._last_pong > self.pong_timeout_s:
            why = f"no pong for {now - self._last_pong:.1f} s"
            logger.warning("tablet %s: %s; disconnecting", self.peer, why)
            self.protocol_error.emit(f"tablet gone: {why}")
            if self._conn is not None:
                self._conn.abort()
            return
        self._ping_seq += 1
        self.send(Ping(self._ping_seq, now))

    def disconnect_tablet(self, reason: str = "") -> None:
        """Close the tablet's connection (after flushing what was written)."""
        self._call.run(lambda: self._disconnect_now(reason))

    def _disconnect_now(self, reason: str) -> None:
        if self._conn is not None:
            logger.info("closing the tablet connection %s: %s", self.peer, reason)
            self._conn.close()

    # ------------------------------------------------------------------ slots
    def _on_new_connection(self) -> None:
        while self._server.hasPendingConnections():
            socket = self._server.nextPendingConnection()
            if socket is None:  # pragma: no cover - Qt contract
                return
            peer = f"{socket.peerAddress().toString()}:{socket.peerPort()}"
            if self._conn is not None:
                self._refuse(socket, peer, f"another tablet ({self.peer}) is connected")
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
        enable_keepalive(socket, *KEEPALIVE)
        conn = QtTcpConnection(socket, parent=self, max_read_bytes=MAX_READ_BYTES)
        self._conn = conn
        self.peer = peer
        self.greeted = False
        self._budget.reset()
        self.policy.reset()
        self._newest_speed = None
        self._last_pong = self._clock()
        # Bound to this connection, not found with sender() (module docstring: lock order).
        conn.object_received.connect(partial(self._on_object, conn))
        conn.batch_finished.connect(partial(self._on_batch_finished, conn))
        conn.frame_error.connect(self._report)
        conn.disconnected.connect(partial(self._on_disconnected, conn))
        self._ping_timer.start()
        logger.info("tablet connected from %s", peer)
        self.connected.emit(peer)

    def _on_disconnected(self, conn: QtTcpConnection) -> None:
        if conn is not self._conn or self._conn is None:
            return
        self._conn = None
        self._ping_timer.stop()
        conn.deleteLater()
        logger.info("tablet %s disconnected; waiting for the next one", self.peer)
        self.peer = ""
        self.greeted = False
        self.disconnected.emit()

    def _report(self, error: ProtocolError) -> None:
        self.send(ErrorReport.from_exception(error, self.limits))
        self.protocol_error.emit(f"{error.code}: {error.message}")
        fatal = isinstance(error, FrameTooLarge)
        if self._budget.record(self._clock(), fatal=fatal):
            why = "frame too large" if fatal else "repeated protocol errors"
            self.disconnect_tablet(why)

    def _on_object(self, conn: QtTcpConnection, obj: object) -> None:
        if conn is not self._conn:
            return  # a turn still running for a connection that was just dropped
        if not self.policy.admit(obj, self._clock()):
            return
        try:
            msg = decode_tablet_message(obj, self.limits)
        except ProtocolError as exc:
            self._report(exc)
            return
        if isinstance(msg, Speed):
            self._newest_speed = msg  # only the newest of a turn is passed on
        elif isinstance(msg, Hello):
            self._on_hello(msg)
        elif isinstance(msg, Pong):
            self._last_pong = self._clock()
            self.latency_measured.emit(max(0.0, msg.round_trip(self._last_pong)))
        elif isinstance(msg, Ping):
            self.send(msg.pong())
        elif isinstance(msg, ErrorReport):
            self.protocol_error.emit(f"tablet reports {msg.code}: {msg.message}")
        else:
            self.message_received.emit(msg)

    def _on_batch_finished(self, conn: QtTcpConnection) -> None:
        if conn is not self._conn:
            return
        speed, self._newest_speed = self._newest_speed, None
        if speed is not None:
            self.speed_received.emit(speed)
        error = self.policy.end_turn(self._clock())
        if error is not None and self._conn is not None:
            logger.warning("tablet %s: %s", self.peer, error)
            self.send(ErrorReport("rate_limited", error))

    def _on_hello(self, hello: Hello) -> None:
        if hello.protocol != PROTOCOL_VERSION:
            reason = (
                f"protocol {hello.protocol} is not supported; this station speaks "
                f"protocol {PROTOCOL_VERSION}"
            )
            self.send(Refused(reason))
            self.refused.emit(self.peer, reason)
            self.disconnect_tablet(reason)
            return
        self.greeted = True
        self.send(Welcome(PROTOCOL_VERSION, self._robot_name()))
