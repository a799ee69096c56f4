"""Main menu of the Tablet (thesis §4.2.1.1): connection state, average latency, and the ways in.

"In the main menu, the connection status to the Base Station is displayed as well as the average
latency in the communication. The user can choose to take control of the robot using a virtual
joystick ... or open the map interface." Added: Home, Report a malfunction, language switch.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QWidget

from interbot_qt.layout import button, column
from tablet_app.translations import Retranslated


class QtMainMenu(Retranslated, QWidget):
    """Big buttons; the window feeds it the connection text and the latency."""

    joystick_requested = Signal()
    map_requested = Signal()
    home_requested = Signal()
    malfunction_requested = Signal()
    language_requested = Signal(str)  # "en" or "pt"

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.title = QLabel()
        self.title.setObjectName("title")
        self.title.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.connection_label = QLabel()
        self.connection_label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.latency_label = QLabel()
        self.latency_label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.joystick_button = button("", self.joystick_requested.emit)
        self.map_button = button("", self.map_requested.emit)
        self.home_button = button("", self.home_requested.emit)
        self.malfunction_button = button("", self.malfunction_requested.emit)
        self.english_button = button("English", lambda: self.language_requested.emit("en"))
        self.portuguese_button = button("Português", lambda: self.language_requested.emit("pt"))
        self.joystick_button.setObjectName("big")
        self.map_button.setObjectName("big")
        grid = QGridLayout()
        grid.addWidget(self.joystick_button, 0, 0)
        grid.addWidget(self.map_button, 0, 1)
        grid.addWidget(self.home_button, 1, 0)
        grid.addWidget(self.malfunction_button, 1, 1)
        grid.addWidget(self.english_button, 2, 0)
        grid.addWidget(self.portuguese_button, 2, 1)
        labels = (self.title, self.connection_label, self.latency_label)
        column(*labels, 1, (grid, 4), 1, parent=self)
        self._latency_ms: float | None = None
        self.retranslate()

    def set_connection_text(self, text: str) -> None:
        self.connection_label.setText(text)

    def set_latency(self, latency_ms: float | None) -> None:
        self._latency_ms = latency_ms
        self._show_latency()

    def _show_latency(self) -> None:
        if self._latency_ms is None:
            self.latency_label.setText(self.tr("Average latency: –"))
        else:
            self.latency_label.setText(
                self.tr("Average latency: %1 ms").replace("%1", f"{self._latency_ms:.0f}")
            )

    def retranslate(self) -> None:
        self.title.setText(self.tr("Interbot"))
        self.joystick_button.setText(self.tr("Joystick"))
        self.map_button.setText(self.tr("Map"))
        self.home_button.setText(self.tr("Home"))
        self.malfunction_button.setText(self.tr("Report a malfunction"))
        self._show_latency()
