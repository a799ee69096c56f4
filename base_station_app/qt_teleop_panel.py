"""Teleoperation (thesis §5.3 "Teleoperation"): arrow keypad, mouse joystick, speed limits,
pause/resume of autonomous navigation and a latching EMERGENCY STOP with an explicit Release.

The pad's `QToolButton`s have auto-repeat off; ``pressed`` / ``released`` drive the controller,
which sends on ``station_vel`` every clock tick while held and a zero on release.
"""

from __future__ import annotations

from dataclasses import replace

from PySide6.QtWidgets import (
    QCheckBox,
    QDoubleSpinBox,
    QFormLayout,
    QGridLayout,
    QGroupBox,
    QLabel,
    QToolButton,
    QWidget,
)

from base_station_app.station_config import RANGES
from base_station_app.station_controller import StationController
from base_station_app.teleop import Direction
from interbot_core.safety_text import describe_safety
from interbot_qt.layout import button, column, row
from interbot_qt.qt_joystick import QtJoystick

_PAD = (
    (Direction.FORWARD, "▲", 0, 1),
    (Direction.LEFT, "◀", 1, 0),
    (Direction.RIGHT, "▶", 1, 2),
    (Direction.BACKWARD, "▼", 2, 1),
)


class QtTeleopPanel(QWidget):
    """Arrow pad, joystick, limits, pause/resume, e-stop and release."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        self.estop_button = button("EMERGENCY STOP", controller.emergency_stop)
        self.estop_button.setMinimumHeight(56)
        self.estop_button.setStyleSheet(
            "QPushButton { background: #d00000; color: white; font-size: 18px; font-weight: bold; }"
        )
        self.release_button = button("Release emergency stop", controller.release_stop)
        self.estop_label = QLabel()
        self.pause_button = button("Pause navigation", controller.commands.pause)
        self.resume_button = button("Resume navigation", controller.commands.resume)

        pad_box = QGroupBox("Arrow pad (or arrows / WASD on the map)")
        grid = QGridLayout(pad_box)
        self.pad: dict[Direction, QToolButton] = {}
        for direction, arrow, r, col in _PAD:
            key = QToolButton()
            key.setText(arrow)
            key.setStyleSheet("font-size: 28px;")
            key.setAutoRepeat(False)
            key.setMinimumSize(64, 64)
            key.setToolTip(f"drive {direction.value}")
            key.pressed.connect(lambda d=direction: controller.press(d))
            key.released.connect(lambda d=direction: controller.release(d))
            grid.addWidget(key, r, col)
            self.pad[direction] = key
        self.joystick = QtJoystick(
            controller.config.teleop_linear_max, controller.config.teleop_angular_max
        )
        self.joystick.setMinimumSize(180, 180)

        limits = QGroupBox("Maximum teleoperation speeds")
        form = QFormLayout(limits)
        self.linear_max = self._spin("teleop_linear_max", " m/s")
        self.angular_max = self._spin("teleop_angular_max", " rad/s")
        form.addRow("linear", self.linear_max)
        form.addRow("angular", self.angular_max)

        # Issue 17: assisted driving (robot-side) and what the collision monitor is doing.
        self.assist_check = QCheckBox("Assisted driving (slide along walls, through doors)")
        self.assist_check.setChecked(controller.robot_link.assist)
        self.monitor_label = QLabel("Collision monitor: no report")
        self.monitor_label.setWordWrap(True)
        self.monitor_label.setToolTip(
            "The robot's collision monitor on the laser: NOT a certified safety system. "
            "The emergency stop is."
        )
        column(
            self.estop_button,
            row(self.release_button, (self.estop_label, 1)),
            row(self.pause_button, self.resume_button),
            (row(pad_box, (self.joystick, 1)), 1),
            limits,
            self.assist_check,
            self.monitor_label,
            parent=self,
        )
        self.joystick.speed_changed.connect(self._on_joystick)
        self.joystick.released.connect(lambda: controller.set_joystick(0.0, 0.0, False))
        self.linear_max.editingFinished.connect(self._apply_limits)
        self.angular_max.editingFinished.connect(self._apply_limits)
        controller.estop_changed.connect(self._on_estop)
        self.assist_check.toggled.connect(controller.robot_link.set_assist)
        controller.frame_ready.connect(self._on_frame)
        controller.config_changed.connect(self._on_config)
        self._on_estop(controller.estop_latched)

    def _spin(self, name: str, suffix: str) -> QDoubleSpinBox:
        lo, hi, _ = RANGES[name]
        spin = QDoubleSpinBox()
        spin.setRange(lo, hi)
        spin.setDecimals(2)
        spin.setSingleStep(0.05)
        spin.setSuffix(suffix)
        spin.setValue(getattr(self._controller.config, name))
        return spin

    def _on_joystick(self, linear: float, angular: float) -> None:
        self._controller.set_joystick(linear, angular, self.joystick.state.pressed)

    def _apply_limits(self) -> None:
        c = self._controller
        new = replace(
            c.config,
            teleop_linear_max=self.linear_max.value(),
            teleop_angular_max=self.angular_max.value(),
        )
        if new != c.config:
            c.set_config(new)

    def _on_config(self, config: object) -> None:
        c = self._controller.config
        for spin, value in (
            (self.linear_max, c.teleop_linear_max),
            (self.angular_max, c.teleop_angular_max),
        ):
            spin.blockSignals(True)
            spin.setValue(value)
            spin.blockSignals(False)
        self.joystick.set_limits(c.teleop_linear_max, c.teleop_angular_max)

    def _on_frame(self) -> None:
        safety = self._controller.selected.state.safety
        if safety is None:
            return
        said = describe_safety(safety.zone, safety.distance)
        self.monitor_label.setText(f"Collision monitor: {said.text}")
        colour = {"info": "#060", "warning": "#a60", "error": "#c00"}[said.level]
        self.monitor_label.setStyleSheet(f"color: {colour}; font-weight: bold;")

    def _on_estop(self, latched: bool) -> None:
        self.release_button.setEnabled(latched)
        self.estop_label.setText("STOP LATCHED" if latched else "")
        self.estop_label.setStyleSheet("color: #c00; font-weight: bold;")
        for key in self.pad.values():
            key.setEnabled(not latched)
        self.joystick.setEnabled(not latched)
