"""Asked at start-up when several robots are online and none was chosen (issue 14).

A restarted station never commands "the first robot seen": with no ``--robot`` and no saved
choice it shows this dialog, one large button per robot; the operator's click selects it (and
the main window saves the choice). Closing it leaves the station commanding nobody; the robot
list and the toolbar selector still offer every robot.
"""

from __future__ import annotations

from PySide6.QtWidgets import QDialog, QLabel, QPushButton, QVBoxLayout, QWidget

from base_station_app.station_controller import StationController


class QtRobotChoiceDialog(QDialog):
    """ "Which robot should this station command?" with a button per robot."""

    def __init__(
        self,
        controller: StationController,
        robot_ids: tuple[str, ...],
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.setObjectName("robot_choice")
        self.setWindowTitle("Choose the robot to command")
        self._controller = controller
        layout = QVBoxLayout(self)
        layout.addWidget(
            QLabel(
                f"{len(robot_ids)} robots are online and none was chosen "
                "(no --robot, no saved choice).\nWhich one should this station command?"
            )
        )
        self.buttons: dict[str, QPushButton] = {}
        for robot_id in robot_ids:
            button = QPushButton(robot_id)
            button.setObjectName(f"choose_{robot_id}")
            button.setMinimumHeight(40)
            button.clicked.connect(lambda _=False, r=robot_id: self._choose(r))
            layout.addWidget(button)
            self.buttons[robot_id] = button

    def _choose(self, robot_id: str) -> None:
        self._controller.select_robot(robot_id)
        self.accept()
