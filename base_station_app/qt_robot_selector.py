"""The robot the station commands, chosen from the toolbar (issue 14): always in sight.

A combo box of every robot seen (offline ones marked); choosing one makes the station command
it. It reflects the controller (echoes blocked with `QSignalBlocker`) and holds no state.
"""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker
from PySide6.QtWidgets import QComboBox, QWidget

from base_station_app.station_controller import StationController

NONE_TEXT = "— choose a robot —"


class QtRobotSelector(QComboBox):
    """``Commanding: [bot2 ▼]`` in the main toolbar."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("robot_selector")
        self.setToolTip("The robot this station commands (keys, tasks, tablet)")
        self.setMinimumContentsLength(14)
        self._controller = controller
        self._shown: list[str] = []
        controller.robots_changed.connect(self.refresh)
        controller.robot_selected.connect(lambda _: self.refresh())
        self.activated.connect(self._on_activated)
        self.refresh()

    def refresh(self) -> None:
        c = self._controller
        robots = c.robots
        selected = c.selected_robot
        texts = ([] if selected else [NONE_TEXT]) + [
            r + ("" if online else " (offline)") for r, online in robots.items()
        ]
        with QSignalBlocker(self):
            if texts != self._shown:
                self._shown = texts
                self.clear()
                if not selected:
                    self.addItem(NONE_TEXT, "")
                for robot_id in robots:
                    self.addItem(texts[self.count()], robot_id)
            index = self.findData(selected or "")
            self.setCurrentIndex(max(index, 0))

    def _on_activated(self, index: int) -> None:
        robot_id = str(self.itemData(index) or "")
        if robot_id:
            self._controller.select_robot(robot_id)
