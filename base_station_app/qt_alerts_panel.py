"""The station's alert list: time, robot, what happened, how often; acknowledge one or all.

Draws `StationController.alerts` (`base_station_app.alerts`), newest first; unacknowledged
alerts are bold, severe ones (collision, fault, blocked route, lost, offline) red. With "Sound"
checked, a new or repeated unacknowledged alert beeps. The window's toolbar badge shows the
count of unacknowledged alerts.
"""

from __future__ import annotations

import time

from PySide6.QtCore import Qt
from PySide6.QtGui import QBrush, QColor, QFont
from PySide6.QtWidgets import (
    QAbstractItemView,
    QApplication,
    QCheckBox,
    QTableWidget,
    QTableWidgetItem,
    QWidget,
)

from base_station_app.alerts import Alert
from base_station_app.station_controller import StationController
from interbot_qt.layout import button, column, row

COLUMNS = ("time", "robot", "kind", "what", "times")


class QtAlertsPanel(QWidget):
    """A table of alerts with Acknowledge, Acknowledge all and a sound switch."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        self._version = -1
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels([c.capitalize() for c in COLUMNS])
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.horizontalHeader().setStretchLastSection(False)
        self.table.horizontalHeader().setSectionResizeMode(
            3, self.table.horizontalHeader().ResizeMode.Stretch
        )
        self.table.verticalHeader().setVisible(False)
        self.ack_button = button("Acknowledge", self._acknowledge_selected)
        self.ack_all_button = button("Acknowledge all", self._acknowledge_all)
        self.sound_box = QCheckBox("Sound")
        buttons = row(self.ack_button, self.ack_all_button)
        buttons.addStretch(1)
        buttons.addWidget(self.sound_box)
        column((self.table, 1), buttons, parent=self)
        controller.alert_raised.connect(self._on_alert)
        controller.clocked.connect(self.refresh)
        self.refresh()

    def _on_alert(self, alert: Alert) -> None:
        if self.sound_box.isChecked() and not alert.acknowledged:
            QApplication.beep()
        self.refresh()

    def _acknowledge_selected(self) -> None:
        for line in {i.row() for i in self.table.selectedIndexes()}:
            item = self.table.item(line, 0)
            if item is not None:
                self._controller.alerts.acknowledge(int(item.data(Qt.ItemDataRole.UserRole)))
        self.refresh()

    def _acknowledge_all(self) -> None:
        self._controller.alerts.acknowledge_all()
        self.refresh()

    def refresh(self) -> None:
        alerts = self._controller.alerts
        if alerts.version == self._version:
            return
        self._version = alerts.version
        rows = list(reversed(alerts.alerts))
        self.table.setRowCount(len(rows))
        bold = QFont(self.font())
        bold.setBold(True)
        for r, alert in enumerate(rows):
            texts = (
                time.strftime("%H:%M:%S", time.localtime(alert.last_wall)),
                alert.robot,
                alert.kind,
                alert.text,
                f"×{alert.count}",
            )
            for c, text in enumerate(texts):
                item = QTableWidgetItem(text)
                if c == 0:
                    item.setData(Qt.ItemDataRole.UserRole, alert.id)
                if not alert.acknowledged:
                    item.setFont(bold)
                    if alert.severe:
                        item.setForeground(QBrush(QColor(190, 0, 0)))
                self.table.setItem(r, c, item)
        self.table.resizeColumnsToContents()
