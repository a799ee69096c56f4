"""Robots (thesis §4.1.2: the station "could be used to control other, and even multiple,
robots"): every robot whose liveliness token was seen, lost ones marked, and which one to
command.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QLabel,
    QListWidget,
    QListWidgetItem,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from base_station_app.station_controller import StationController


class QtRobotsPanel(QWidget):
    """List of robots and a "Command this robot" button."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        layout = QVBoxLayout(self)
        self.selected_label = QLabel()
        layout.addWidget(self.selected_label)
        self.robot_list = QListWidget()
        layout.addWidget(self.robot_list, 1)
        self.select_button = QPushButton("Command this robot")
        layout.addWidget(self.select_button)
        self.select_button.clicked.connect(self._select)
        controller.robots_changed.connect(self.refresh)
        controller.robot_selected.connect(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        c = self._controller
        selected = c.selected_robot
        self.selected_label.setText(f"Commanding: {selected or 'no robot'}")
        self.robot_list.clear()
        for robot_id, present in sorted(c.robots.items()):
            text = (
                robot_id
                + ("" if present else "  (lost)")
                + ("  ◀ commanding" if robot_id == selected else "")
            )
            item = QListWidgetItem(text)
            item.setData(Qt.ItemDataRole.UserRole, robot_id)
            if not present:
                item.setForeground(QColor(200, 0, 0))
            self.robot_list.addItem(item)

    def _select(self) -> None:
        item = self.robot_list.currentItem()
        if item is not None:
            self._controller.select_robot(str(item.data(Qt.ItemDataRole.UserRole)))
