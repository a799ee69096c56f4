"""The Tablet's connection to the Base Station (thesis §4.2.1.2 Communication Handler, §5.3.1).

`TabletConnection` owns the socket (through `interbot_qt.qt_tcp_connection.QtTcpConnection`),
passes every validated Base Station message on (``message_received``) and sends Tablet messages.
Beyond the thesis it: says ``hello`` on connect (docs/protocol.md), answers pings, pings the
station every second to keep the average round-trip latency shown on the main menu and beside
the joystick, decides when the link is lossy (`tablet_app.link_health.LatencyMonitor`), and
reconnects by itself with exponential back-off (`tablet_app.link_health.ReconnectBackoff`),
for instance when the tablet moves to another Wi-Fi hotspot (§5.3.4).
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject, Qt, QTimer, Signal

from interbot_core.protocol import (
    PROTOCOL_VERSION,
    ErrorReport,
    Hello,
    Message,
    Ping,
    Pong,
    ProtocolError,
    Refused,
    RobotName,
    Welcome,
    decode_station_message,
)
from interbot_qt.qt_tcp_connection import QtTcpConnection
from tablet_app.link_health import (
    BackoffConfig,
    LatencyConfig,
    LatencyMonitor,
    ReconnectBackoff,
)

logger = logging.getLogger(__name__)


class ConnectionState(enum.StrEnum):
    DISCONNECTED = "disconnected"  # not started, or stopped
    CONNECTING = "connecting"
    CONNECTED = "connected"
    WAITING = "waiting"  # a reconnect is scheduled


class TabletConnection(QObject):
    """Client side of the Tablet <-> Base Station protocol over TCP."""

    message_received = Signal(object)  # a StationMessage other than the connection's own (below)
    robot_name_changed = Signal(str)  # the robot this tablet drives (Welcome, RobotName)
    refused = Signal(str)  # reason
    protocol_error = Signal(str)  # a frame or message from the station we could not use
    connected = Signal()
    disconnected = Signal()
    state_changed = Signal(str)  # ConnectionState value
    reconnect_scheduled = Signal(float)  # delay [s]
    latency_changed = Signal(float)  # mean round trip [ms]
    link_lossy_changed = Signal(bool)

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 5555,
        parent: QObject | None = None,
        *,
        ping_interval: float = 1.0,  # [s]
        health_interval: float = 0.25,  # [s] how often "lossy" is re-evaluated
        connect_timeout: float = 3.0,  # [s]
        latency: LatencyConfig | None = None,
        backoff: BackoffConfig | None = None,
        clock: Callable[[], float] = time.monotonic,
        link: QtTcpConnection | None = None,
    ) -> None:
        super().__init__(parent)
        self.host, self.port = host, port
        self._clock = clock
        # ``link``: e.g. `tablet_app.pairing.PairedTlsConnection` (TLS + token, issue 15).
        self._link = link if link is not None else QtTcpConnection(parent=self)
        self._link.setParent(self)
        self._monitor = LatencyMonitor(latency)
        self._backoff = ReconnectBackoff(backoff)
        self.state = ConnectionState.DISCONNECTED
        self._running = False
        self.is_lossy = True  # commands would not be obeyed: not connected, or pongs late/slow
        self._seq = 0
        self.robot_name = ""

        self._ping_timer = self._timer(ping_interval, self._send_ping)
        self._health_timer = self._timer(health_interval, self._check_health)
        self._reconnect_timer = self._timer(0.5, self._connect_now, single_shot=True)
        self._connect_timer = self._timer(connect_timeout, self._on_connect_timeout, True)

        self._link.connected.connect(self._on_connected)
        self._link.disconnected.connect(self._on_disconnected)
        self._link.socket_error.connect(self._on_socket_error)
        self._link.object_received.connect(self._on_object)
        self._link.frame_error.connect(self._on_protocol_error)
        # The messages the connection handles itself; the others go out as message_received.
        self._handlers: dict[type[Message], Callable[[Any], None]] = {
            Welcome: self._on_welcome,
            RobotName: self._on_robot_name,
            Refused: self._on_refused,
            Ping: self._on_ping,
            Pong: self._on_pong,
        }

    def _timer(
        self, interval: float, slot: Callable[[], None], single_shot: bool = False
    ) -> QTimer:
        timer = QTimer(self)
        timer.setTimerType(Qt.TimerType.PreciseTimer)
        timer.setInterval(round(interval * 1000))
        timer.setSingleShot(single_shot)
        timer.timeout.connect(slot)
        return timer

    # ---------------------------------------------------------------- public API

    @property
    def is_connected(self) -> bool:
        return self.state == ConnectionState.CONNECTED

    @property
    def average_latency_ms(self) -> float | None:
        average = self._monitor.average
        return None if average is None else average * 1000.0

    def start(self) -> None:
        """Connect, and keep reconnecting until `stop`."""
        self._running = True
        self._backoff.reset()
        self._connect_now()

    def stop(self) -> None:
        self._running = False
        for timer in (self._ping_timer, self._health_timer, self._reconnect_timer):
            timer.stop()
        self._connect_timer.stop()
        self._link.abort()
        self._set_state(ConnectionState.DISCONNECTED)
        self._set_lossy(True)

    def send(self, msg: Message) -> bool:
        """Send one message (one socket write); False when not connected."""
        if not self.is_connected:
            logger.info("not connected to the Base Station; %s not sent", msg.KEY)
            return False
        return self._link.send(msg)

    # ---------------------------------------------------------------- connection life cycle
    def _set_state(self, state: ConnectionState) -> None:
        if state != self.state:
            self.state = state
            self.state_changed.emit(state.value)

    def _set_lossy(self, lossy: bool) -> None:
        if lossy != self.is_lossy:
            self.is_lossy = lossy
            self.link_lossy_changed.emit(lossy)

    def _connect_now(self) -> None:
        if not self._running:
            return
        self._link.abort()
        self._set_state(ConnectionState.CONNECTING)
        self._connect_timer.start()
        self._link.connect_to_host(self.host, self.port)

    def _schedule_reconnect(self) -> None:
        self._ping_timer.stop()
        self._health_timer.stop()
        self._connect_timer.stop()
        self._set_lossy(True)
        if not self._running or self._reconnect_timer.isActive():
            return
        delay = self._backoff.next_delay()
        self._reconnect_timer.setInterval(round(delay * 1000))
        self._reconnect_timer.start()
        self._set_state(ConnectionState.WAITING)
        self.reconnect_scheduled.emit(delay)
        logger.info("Base Station %s:%d unreachable; retry in %.1f s", self.host, self.port, delay)

    def _on_connected(self) -> None:
        self._connect_timer.stop()
        self._backoff.reset()
        self._monitor.reset()
        self._set_state(ConnectionState.CONNECTED)
        self._link.send(Hello(PROTOCOL_VERSION, "tablet"))
        self._ping_timer.start()
        self._health_timer.start()
        self._set_lossy(False)
        self.connected.emit()
        logger.info("connected to the Base Station %s:%d", self.host, self.port)

    def _on_disconnected(self) -> None:
        was_connected = self.state == ConnectionState.CONNECTED
        if was_connected:
            logger.info("Base Station closed the connection")
        self._schedule_reconnect()
        if was_connected:
            self.disconnected.emit()

    def _on_socket_error(self, text: str) -> None:
        logger.info("socket error: %s", text)
        if self.state != ConnectionState.CONNECTED:
            self._schedule_reconnect()

    def _on_connect_timeout(self) -> None:
        if self.state == ConnectionState.CONNECTING:
            logger.info("connecting to %s:%d timed out", self.host, self.port)
            self._link.abort()
            self._schedule_reconnect()

    # ---------------------------------------------------------------- latency
    def _send_ping(self) -> None:
        now = self._clock()
        self._seq += 1
        self._monitor.ping_sent(self._seq, now)
        self._link.send(Ping(self._seq, now))
        self._check_health()

    def _on_pong(self, pong: Pong) -> None:
        if self._monitor.pong_received(pong.seq, self._clock()) is not None:
            average = self._monitor.average
            assert average is not None
            self.latency_changed.emit(average * 1000.0)
        self._check_health()

    def _check_health(self) -> None:
        if self.is_connected:
            self._set_lossy(self._monitor.is_lossy(self._clock()))

    # ---------------------------------------------------------------- incoming messages
    def _on_object(self, obj: object) -> None:
        try:
            msg = decode_station_message(obj)
        except ProtocolError as exc:
            self._on_protocol_error(exc)
            return
        self._handlers.get(type(msg), self.message_received.emit)(msg)

    def _on_protocol_error(self, exc: ProtocolError) -> None:
        logger.warning("invalid message from the Base Station: %s", exc.message)
        self._link.send(ErrorReport.from_exception(exc))
        self.protocol_error.emit(exc.message)

    def _on_ping(self, ping: Ping) -> None:
        self._link.send(ping.pong())

    def _on_welcome(self, welcome: Welcome) -> None:
        self.robot_name = welcome.robot
        self.robot_name_changed.emit(welcome.robot)

    def _on_robot_name(self, msg: RobotName) -> None:
        """The operator now commands another robot: this tablet drives that one."""
        self.robot_name = msg.name
        self.robot_name_changed.emit(msg.name)

    def _on_refused(self, refused: Refused) -> None:
        logger.warning("Base Station refused the tablet: %s", refused.reason)
        self.refused.emit(refused.reason)
