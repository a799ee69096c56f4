"""Bar shown while the robot moves to a goal (thesis §5.2.2: "during this process the user can
pause, resume or cancel the navigation using on-screen buttons"; §4.2.1.1 manual control).

Destination, progress (0-100 %, computed by the window from the remaining distance), Pause,
Resume, Cancel and Manual control.
"""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QFrame, QLabel, QProgressBar, QWidget

from interbot_qt.layout import button, row
from tablet_app.translations import Retranslated


class QtMotionBar(Retranslated, QFrame):
    pause_requested = Signal()
    resume_requested = Signal()
    cancel_requested = Signal()
    manual_requested = Signal()

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("motionBar")
        self.destination_label = QLabel()
        self.progress = QProgressBar()
        self.progress.setRange(0, 100)
        self.pause_button = button("", self.pause_requested.emit)
        self.resume_button = button("", self.resume_requested.emit)
        self.cancel_button = button("", self.cancel_requested.emit)
        self.manual_button = button("", self.manual_requested.emit)
        buttons = (self.pause_button, self.resume_button, self.cancel_button, self.manual_button)
        row(
            (self.destination_label, 2), (self.progress, 2), *((b, 1) for b in buttons), parent=self
        )
        self._destination = ""
        self.set_paused(False)
        self.retranslate()

    def set_destination(self, name: str) -> None:
        self._destination = name
        self._show_destination()

    def set_progress(self, percent: int) -> None:
        self.progress.setValue(max(0, min(100, percent)))

    def set_paused(self, paused: bool) -> None:
        self.pause_button.setEnabled(not paused)
        self.resume_button.setEnabled(paused)

    def _show_destination(self) -> None:
        self.destination_label.setText(self.tr("Going to %1").replace("%1", self._destination))

    def retranslate(self) -> None:
        self.pause_button.setText(self.tr("Pause"))
        self.resume_button.setText(self.tr("Resume"))
        self.cancel_button.setText(self.tr("Cancel"))
        self.manual_button.setText(self.tr("Manual control"))
        self._show_destination()
