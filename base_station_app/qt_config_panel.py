"""Configuration on the fly (thesis §5.3 "Configurations"): approach and final tolerances,
teleoperation and planner speed limits, the tablet latency ceiling. "Apply" validates them into a
`StationConfig` and hands it to the controller, which applies it at once and keeps it in the
station file.
"""

from __future__ import annotations

from PySide6.QtWidgets import QDoubleSpinBox, QFormLayout, QLabel, QWidget

from base_station_app.station_config import RANGES, StationConfig, StationConfigError
from base_station_app.station_controller import StationController
from interbot_qt.layout import button, column

TITLES = {
    "approach_tolerance": "Approach tolerance (intermediate goals)",
    "goal_tolerance": "Final position tolerance",
    "yaw_tolerance": "Final orientation tolerance",
    "teleop_linear_max": "Teleoperation max linear speed",
    "teleop_angular_max": "Teleoperation max angular speed",
    "planner_linear_max": "Planner max linear speed",
    "planner_angular_max": "Planner max angular speed",
    "latency_ceiling": "Tablet latency ceiling (watchdog)",
}


class QtConfigPanel(QWidget):
    """One spin box per `StationConfig` field and an Apply button."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        form = QFormLayout()
        self.spins: dict[str, QDoubleSpinBox] = {}
        for name, (lo, hi, unit) in RANGES.items():
            spin = QDoubleSpinBox()
            spin.setRange(lo, hi)
            spin.setDecimals(3)
            spin.setSingleStep(0.05)
            spin.setSuffix(f" {unit}")
            form.addRow(TITLES[name], spin)
            self.spins[name] = spin
        self.apply_button = button("Apply", self.apply)
        self.message = QLabel()
        column(form, self.apply_button, self.message, 1, parent=self)
        controller.config_changed.connect(self.show_config)
        self.show_config(controller.config)

    def show_config(self, config: object) -> None:
        cfg = self._controller.config
        for name, spin in self.spins.items():
            spin.blockSignals(True)
            spin.setValue(getattr(cfg, name))
            spin.blockSignals(False)

    def apply(self) -> bool:
        try:
            config = StationConfig(**{n: s.value() for n, s in self.spins.items()})
        except StationConfigError as exc:
            self.message.setText(str(exc))
            return False
        self._controller.set_config(config)
        self.message.setText("applied")
        return True
