"""Robots (thesis §4.1.2: the station "could be used to control other, and even multiple,
robots"; issue 14): every robot whose liveliness token was seen, with its state, what it does and
how many tasks wait in its own queue, and which one to command.

The list is drawn from the controller's `RobotView` snapshots (no robot state here); a click on a
row and "Command this robot" (or a double click) makes the station command that robot.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QLabel,
    QListWidget,
    QListWidgetItem,
    QVBoxLayout,
    QWidget,
)

from base_station_app.qt_fleet_layer import HEALTH_COLOURS
from base_station_app.station_controller import StationController
from interbot_qt.layout import button


class QtRobotsPanel(QWidget):
    """List of robots and a "Command this robot" button."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        self._shown: list[tuple[str, str]] = []
        layout = QVBoxLayout(self)
        self.selected_label = QLabel()
        layout.addWidget(self.selected_label)
        self.robot_list = QListWidget()
        self.robot_list.setObjectName("robot_list")
        layout.addWidget(self.robot_list, 1)
        self.select_button = button("Command this robot", self._select)
        self.select_button.setObjectName("command_robot")
        layout.addWidget(self.select_button)
        self.robot_list.itemDoubleClicked.connect(lambda _item: self._select())
        controller.robots_changed.connect(self.refresh)
        controller.robot_selected.connect(lambda _: self.refresh())
        controller.tasks_changed.connect(self.refresh)
        controller.clocked.connect(self.refresh)
        self.refresh()

    def refresh(self) -> None:
        c = self._controller
        selected = c.selected_robot
        self.selected_label.setText(f"Commanding: {selected or 'no robot'}")
        rows = [
            (
                v.robot_id,
                f"{v.robot_id}  [{v.health}]  {v.task}"
                + (f"  +{v.queued} queued" if v.queued else "")
                + ("  ◀ commanding" if v.selected else ""),
            )
            for v in c.fleet.views(c.names)
        ]
        if rows == self._shown:
            return
        current = self.robot_list.currentItem()
        keep = None if current is None else current.data(Qt.ItemDataRole.UserRole)
        self._shown = rows
        self.robot_list.clear()
        views = {v.robot_id: v for v in c.fleet.views(c.names)}
        for robot_id, text in rows:
            item = QListWidgetItem(text)
            item.setData(Qt.ItemDataRole.UserRole, robot_id)
            item.setForeground(QColor(*HEALTH_COLOURS[views[robot_id].health]))
            self.robot_list.addItem(item)
            if robot_id == keep:
                self.robot_list.setCurrentItem(item)

    def row_of(self, robot_id: str) -> QListWidgetItem | None:
        for i in range(self.robot_list.count()):
            item = self.robot_list.item(i)
            if item.data(Qt.ItemDataRole.UserRole) == robot_id:
                return item
        return None

    def _select(self) -> None:
        item = self.robot_list.currentItem()
        if item is not None:
            self._controller.select_robot(str(item.data(Qt.ItemDataRole.UserRole)))
