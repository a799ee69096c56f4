"""Map screen of the Tablet (thesis §5.2.1, §5.2.2, Fig. 5.3, Fig. 5.4, Fig. 6.2a).

The interactive map (`tablet_app.qt_map_view.QtMapView`) with the room-independent actions
beside it: Guided tour, Home, Back. When the robot is not localised (``initial_pose: false`` or
``localisation: unset/lost``) a banner asks for help (§5.2.2.1): "Help me!" highlights the rooms
and asks the user to drive the robot with the joystick to one of them and tap it.
"""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QFrame, QLabel, QWidget

from interbot_qt.layout import button, column, row
from tablet_app.qt_map_view import QtMapView
from tablet_app.tablet_session import Help
from tablet_app.translations import Retranslated


class QtMapScreen(Retranslated, QWidget):
    """Map plus actions; the window decides what a room tap means."""

    tour_requested = Signal()
    home_requested = Signal()
    back_requested = Signal()
    help_requested = Signal()
    joystick_requested = Signal()

    def __init__(self, map_view: QtMapView, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.map_view = map_view
        self.help_banner = QFrame()
        self.help_banner.setObjectName("helpBanner")
        self.help_text = QLabel()
        self.help_text.setWordWrap(True)
        self.help_button = button("", self.help_requested.emit)
        self.help_button.setObjectName("helpButton")
        self.drive_button = button("", self.joystick_requested.emit)
        column(self.help_text, self.help_button, self.drive_button, parent=self.help_banner)
        self.help_banner.setVisible(False)
        self.tour_button = button("", self.tour_requested.emit)
        self.home_button = button("", self.home_requested.emit)
        self.back_button = button("", self.back_requested.emit)
        side = column(self.help_banner, 1, self.tour_button, self.home_button, self.back_button)
        row((map_view, 4), (side, 1), parent=self)
        self._help = Help.NONE
        self._room = ""
        self.retranslate()

    def set_help_state(self, help: Help, room: str = "") -> None:
        """Where "Help me!" stands (`tablet_session.Help`); ``room`` is the one being checked."""
        self._help, self._room = help, room
        shown = help is not Help.NONE
        self.help_banner.setVisible(shown)
        self.help_button.setVisible(help is Help.OFFERED)
        self.drive_button.setVisible(help is Help.CHOOSING)
        self.map_view.set_highlight(help is Help.CHOOSING)
        self._show_help_text()

    def _show_help_text(self) -> None:
        if self._help is Help.CHOOSING:
            self.help_text.setText(
                self.tr(
                    "Drive me with the joystick to one of the highlighted rooms, "
                    "then tap that room on the map."
                )
            )
        elif self._help is Help.CHECKING:
            self.help_text.setText(self.tr("Checking that I am at %1…").replace("%1", self._room))
        else:
            self.help_text.setText(self.tr("I do not know where I am."))

    def retranslate(self) -> None:
        self.help_button.setText(self.tr("Help me!"))
        self.drive_button.setText(self.tr("Joystick"))
        self.tour_button.setText(self.tr("Guided tour"))
        self.home_button.setText(self.tr("Home"))
        self.back_button.setText(self.tr("Menu"))
        self._show_help_text()
