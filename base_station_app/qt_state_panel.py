"""Robot state (thesis §4.2.2.1): speeds, orientation, localisation, battery, the multiplexer's
active source, the e-stop, the current task, the distance to the next goal and the status log
(messages and errors). Refreshed from the controller's ``frame_ready`` / ``clocked`` signals.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QFormLayout,
    QGroupBox,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QVBoxLayout,
    QWidget,
)

from base_station_app.display_text import (
    UNSET,
    estop_text,
    localisation_text,
    orientation_text,
    position_text,
)
from base_station_app.qt_speedometer import QtSpeedometer
from base_station_app.station_controller import StationController
from interbot_core.safety_text import describe_safety
from interbot_qt.layout import row

LEVEL_COLOURS = {
    "info": QColor(20, 20, 20),
    "warning": QColor(170, 100, 0),
    "error": QColor(200, 0, 0),
}


class QtStatePanel(QWidget):
    """Speedometers, a state form and the status log."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        self._version = -1
        layout = QVBoxLayout(self)
        cfg = controller.config
        self.linear_dial = QtSpeedometer(
            "linear", "m/s", max(cfg.teleop_linear_max, cfg.planner_linear_max)
        )
        self.angular_dial = QtSpeedometer(
            "angular", "rad/s", max(cfg.teleop_angular_max, cfg.planner_angular_max)
        )
        layout.addLayout(row(self.linear_dial, self.angular_dial))
        box = QGroupBox("Robot")
        form = QFormLayout(box)
        self.labels: dict[str, QLabel] = {}
        for key, title in (
            ("robot", "Robot"),
            ("pose", "Position"),
            ("orientation", "Orientation"),
            ("localisation", "Localisation"),
            ("battery", "Battery"),
            ("mux", "Velocity source"),
            ("monitor", "Collision monitor"),
            ("estop", "Emergency stop"),
            ("task", "Current task"),
            ("distance", "Distance to next goal"),
            ("status", "Status"),
        ):
            label = QLabel(UNSET)
            label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
            label.setWordWrap(True)
            self.labels[key] = label
            form.addRow(title + ":", label)
        layout.addWidget(box)
        layout.addWidget(QLabel("Status log"))
        self.log_list = QListWidget()
        layout.addWidget(self.log_list, 1)
        for entry in controller.selected.state.log:
            self._add_log(entry.level, entry.text)
        controller.log_added.connect(self._add_log)
        controller.frame_ready.connect(self.refresh)
        controller.clocked.connect(self.refresh_task)
        controller.estop_changed.connect(lambda _: self.refresh_task())
        self.refresh()
        self.refresh_task()

    def _add_log(self, level: str, text: str) -> None:
        item = QListWidgetItem(f"[{level}] {text}")
        item.setForeground(LEVEL_COLOURS.get(level, QColor(20, 20, 20)))
        self.log_list.addItem(item)
        while self.log_list.count() > 500:
            self.log_list.takeItem(0)
        self.log_list.scrollToBottom()

    def refresh(self) -> None:
        c = self._controller
        s = c.selected.state
        if s.version == self._version:
            return
        self._version = s.version
        L = self.labels
        L["robot"].setText(c.selected_robot or "none selected")
        speed = s.odom if s.odom is not None else s.cmd_vel
        if speed is not None:
            self.linear_dial.set_value(speed.linear)
            self.angular_dial.set_value(speed.angular)
        L["pose"].setText(position_text(s.pose))
        L["orientation"].setText(orientation_text(s.pose))
        loc = s.localisation
        L["localisation"].setText(localisation_text(loc, s.pose))
        if s.battery is not None:
            b = s.battery
            L["battery"].setText(f"{b.voltage:.1f} V, {b.soc * 100:.0f} %, {b.current:.1f} A")
        if s.mux is not None:
            locks = ", ".join(s.mux.active_locks) or "no locks"
            L["mux"].setText(f"{s.mux.source or 'none (zero)'}; {locks}")
        if s.safety is not None:
            said = describe_safety(s.safety.zone, s.safety.distance)
            assisted = ", ".join(s.safety.assisted) or "none"
            L["monitor"].setText(f"{said.text}; assisted: {assisted}")

    def refresh_task(self) -> None:
        c = self._controller
        L = self.labels
        text, alarm = estop_text(c.estop_latched, c.selected.state.estop_engaged)
        L["estop"].setText(text)
        L["estop"].setStyleSheet("color: #c00; font-weight: bold;" if alarm else "")
        L["task"].setText(c.selected.task_text(c.names))
        d = c.selected.supervisor.distance_to_next_goal
        L["distance"].setText(UNSET if d is None else f"{d:.2f} m")
        L["status"].setText(c.selected.status_text(c.estop_latched))
