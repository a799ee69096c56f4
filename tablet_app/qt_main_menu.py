"""Main menu of the Tablet (thesis §4.2.1.1): connection state, average latency, and the ways in.

"In the main menu, the connection status to the Base Station is displayed as well as the average
latency in the communication. The user can choose to take control of the robot using a virtual
joystick ... or open the map interface." Added: Home, Report a malfunction, language switch.
"""

from __future__ import annotations

from PySide6.QtCore import QEvent, Qt, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QPushButton, QVBoxLayout, QWidget


class QtMainMenu(QWidget):
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
        self.joystick_button = QPushButton()
        self.map_button = QPushButton()
        self.home_button = QPushButton()
        self.malfunction_button = QPushButton()
        self.english_button = QPushButton("English")
        self.portuguese_button = QPushButton("Português")
        for button in (self.joystick_button, self.map_button):
            button.setObjectName("big")
        grid = QGridLayout()
        grid.addWidget(self.joystick_button, 0, 0)
        grid.addWidget(self.map_button, 0, 1)
        grid.addWidget(self.home_button, 1, 0)
        grid.addWidget(self.malfunction_button, 1, 1)
        grid.addWidget(self.english_button, 2, 0)
        grid.addWidget(self.portuguese_button, 2, 1)
        layout = QVBoxLayout(self)
        layout.addWidget(self.title)
        layout.addWidget(self.connection_label)
        layout.addWidget(self.latency_label)
        layout.addStretch(1)
        layout.addLayout(grid, 4)
        layout.addStretch(1)
        self.joystick_button.clicked.connect(self.joystick_requested)
        self.map_button.clicked.connect(self.map_requested)
        self.home_button.clicked.connect(self.home_requested)
        self.malfunction_button.clicked.connect(self.malfunction_requested)
        self.english_button.clicked.connect(lambda: self.language_requested.emit("en"))
        self.portuguese_button.clicked.connect(lambda: self.language_requested.emit("pt"))
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

    def changeEvent(self, event: QEvent) -> None:
        if event.type() == QEvent.Type.LanguageChange:
            self.retranslate()
        super().changeEvent(event)
