"""Joystick screen of the Tablet (thesis §5.2.2.3, Fig. 5.7; §5.3.4).

The `interbot_qt.qt_joystick.QtJoystick` circle, buttons for the maximum linear (0.1-1.0 m/s)
and angular (0.1-2.0 rad/s) speeds, the latency beside it, and a red warning when the link is
lossy: the Base Station's watchdog then discards speed commands (§5.3.4), so "commands will not
be obeyed". While touched, the current command is sent as ``{"speed": ...}`` every 100 ms (a
precise `QTimer`), and one zero on release. Each command carries ``seq`` and ``t`` (issue 11) so
the station can drop one that arrives out of order or late.
"""

from __future__ import annotations

import logging
import time

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QWidget

from interbot_core.protocol import SafetyInfo, Speed
from interbot_qt.layout import button, column, row
from interbot_qt.qt_joystick import QtJoystick
from tablet_app.tablet_connection import TabletConnection
from tablet_app.translations import Retranslated

logger = logging.getLogger(__name__)

SEND_PERIOD_MS = 100
LINEAR_RANGE = (0.1, 0.3)  # [m/s] the robot's multiplexer limits the tablet to 0.3 m/s
ANGULAR_RANGE = (0.1, 1.0)  # [rad/s] and 1 rad/s (resources/config/interbot_mux.yaml)
STEP = 0.1


def _quantise(value: float) -> float:
    """Speeds go on the wire with millimetre / milliradian resolution."""
    return round(value, 3) + 0.0  # + 0.0 turns -0.0 into 0.0


class QtJoystickScreen(Retranslated, QWidget):
    """Teleoperation by touch; sends speed commands through the connection."""

    back_requested = Signal()

    def __init__(self, connection: TabletConnection, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._connection = connection
        self._seq = 0
        self.joystick = QtJoystick(0.3, 0.6)
        self._timer = QTimer(self)
        self._timer.setTimerType(Qt.TimerType.PreciseTimer)
        self._timer.setInterval(SEND_PERIOD_MS)
        self._timer.timeout.connect(self._send_current)

        self.latency_label = QLabel()
        self.warning_label = QLabel()
        self.warning_label.setObjectName("warning")
        self.warning_label.setWordWrap(True)
        self.warning_label.setVisible(False)
        self.monitor_label = QLabel()  # the robot's collision monitor (issue 17)
        self.monitor_label.setObjectName("monitor")
        self.monitor_label.setWordWrap(True)
        self._safety: SafetyInfo | None = None
        self.linear_title = QLabel()
        self.angular_title = QLabel()
        self.linear_value = QLabel()
        self.angular_value = QLabel()
        for label in (self.linear_value, self.angular_value):
            label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.linear_down = button("−", lambda: self._step(-STEP, 0.0))
        self.linear_up = button("+", lambda: self._step(STEP, 0.0))
        self.angular_down = button("−", lambda: self._step(0.0, -STEP))
        self.angular_up = button("+", lambda: self._step(0.0, STEP))
        self.back_button = button("", self.back_requested.emit)

        limits = QGridLayout()
        limits.addWidget(self.linear_title, 0, 0, 1, 3)
        limits.addWidget(self.linear_down, 1, 0)
        limits.addWidget(self.linear_value, 1, 1)
        limits.addWidget(self.linear_up, 1, 2)
        limits.addWidget(self.angular_title, 2, 0, 1, 3)
        limits.addWidget(self.angular_down, 3, 0)
        limits.addWidget(self.angular_value, 3, 1)
        limits.addWidget(self.angular_up, 3, 2)
        side = column(
            self.latency_label,
            self.warning_label,
            self.monitor_label,
            1,
            limits,
            1,
            self.back_button,
        )
        row((self.joystick, 3), (side, 2), parent=self)

        self.joystick.pressed.connect(self._on_pressed)
        self.joystick.released.connect(self._on_released)
        connection.latency_changed.connect(self.set_latency)
        connection.link_lossy_changed.connect(self.set_lossy)
        connection.message_received.connect(
            lambda msg: self.set_safety(msg) if isinstance(msg, SafetyInfo) else None
        )
        self._latency_ms: float | None = connection.average_latency_ms
        self.set_lossy(connection.is_lossy)
        self.retranslate()

    # ---------------------------------------------------------------- sending
    def _speed(self, linear: float, angular: float) -> Speed:
        self._seq += 1
        return Speed(linear, angular, self._seq, round(time.monotonic(), 4))

    def _send_current(self) -> None:
        linear, angular = self.joystick.command()
        self._connection.send(self._speed(_quantise(linear), _quantise(angular)))

    def _on_pressed(self) -> None:
        self._send_current()
        self._timer.start()

    def _on_released(self) -> None:
        self._timer.stop()
        self._connection.send(self._speed(0.0, 0.0))

    def _step(self, d_linear: float, d_angular: float) -> None:
        linear = min(
            LINEAR_RANGE[1], max(LINEAR_RANGE[0], self.joystick.state.linear_max + d_linear)
        )
        angular = min(
            ANGULAR_RANGE[1], max(ANGULAR_RANGE[0], self.joystick.state.angular_max + d_angular)
        )
        self.joystick.set_limits(round(linear, 2), round(angular, 2))
        self._show_limits()

    # ---------------------------------------------------------------- display
    def set_latency(self, latency_ms: float | None) -> None:
        self._latency_ms = latency_ms
        self._show_latency()

    def set_safety(self, info: SafetyInfo) -> None:
        self._safety = info
        self._show_safety()

    def _show_safety(self) -> None:
        info = self._safety
        if info is None:
            self.monitor_label.setText("")
            return
        words = {
            "none": self.tr("Path clear"),
            "slowdown": self.tr("Obstacle near: slowing down"),
            "limit": self.tr("Speed limited"),
            "approach": self.tr("Obstacle ahead: slowing down"),
            "stop": self.tr("Stopped: obstacle too close"),
            "no_data": self.tr("Stopped: the robot cannot see"),
        }[info.zone]
        if info.distance < 0.5 and info.zone != "no_data":
            words += f" ({info.distance * 100:.0f} cm)"
        if info.assisted:
            words += "\n" + self.tr("Driving assistance on")
        self.monitor_label.setText(words)
        colour = {"none": "#060", "stop": "#c00", "no_data": "#c00"}.get(info.zone, "#a60")
        self.monitor_label.setStyleSheet(f"color: {colour}; font-weight: bold;")

    def set_lossy(self, lossy: bool) -> None:
        self.warning_label.setVisible(lossy)

    def _show_latency(self) -> None:
        if self._latency_ms is None:
            self.latency_label.setText(self.tr("Latency: –"))
        else:
            self.latency_label.setText(
                self.tr("Latency: %1 ms").replace("%1", f"{self._latency_ms:.0f}")
            )

    def _show_limits(self) -> None:
        self.linear_value.setText(f"{self.joystick.state.linear_max:.1f} m/s")
        self.angular_value.setText(f"{self.joystick.state.angular_max:.1f} rad/s")

    def retranslate(self) -> None:
        self.warning_label.setText(
            self.tr("Connection is lossy: commands will not be obeyed until it recovers.")
        )
        self.linear_title.setText(self.tr("Maximum linear speed"))
        self.angular_title.setText(self.tr("Maximum angular speed"))
        self.back_button.setText(self.tr("Back"))
        self._show_latency()
        self._show_limits()
        self._show_safety()
