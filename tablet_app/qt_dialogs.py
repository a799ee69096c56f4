"""Dialogs of the Tablet (thesis Figs. 5.4, 5.5a, 5.5b, 6.2b; §4.2.1.1 malfunction report).

* `QtRoomDialog` (Fig. 5.5a): a room's information, "Take me there", and, for rooms that accept
  them, "Request / deliver".
* `QtRequestDialog` (Fig. 5.5b): what to request and where to deliver it.
* `QtTourStopDialog` (Fig. 6.2b): a guided-tour stop's information; Resume or End tour.
* `QtShowRequestDialog`: a request shown to the people in a room; Accept or Decline, then
  "I am taking it to <room>".
* `QtHelpConfirmDialog` (Fig. 5.4): "I am at <room>" to set the initial pose.
* `QtMalfunctionDialog`: collision / wrong position / wrong orientation / other, with text.

They are opened with ``open()`` (window-modal, never a nested event loop) and report by signals;
each sends nothing itself. Room names and info come from the map file and are not translated.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QButtonGroup,
    QComboBox,
    QDialog,
    QLabel,
    QLineEdit,
    QListView,
    QPushButton,
    QRadioButton,
    QWidget,
)

from interbot_core.protocol import MALFUNCTION_KINDS, ShowRequest
from interbot_core.rooms import Room, RoomMap
from interbot_qt.layout import column, row
from tablet_app.qt_keyboard import QtKeyboard
from tablet_app.translations import Retranslated


class _TabletDialog(Retranslated, QDialog):
    HAS_KEYBOARD = False  # dialogs with an on-screen keyboard get most of the screen

    def __init__(self, parent: QWidget | None) -> None:
        super().__init__(parent)
        self.setModal(True)

    def _lay_out(
        self, *rows: QWidget, buttons: tuple[QPushButton, ...], grow: QWidget | None = None
    ) -> None:
        """``rows`` top to bottom (``grow`` takes the spare height), then ``buttons`` in a row."""
        column(*((r, 1) if r is grow else r for r in rows), row(*buttons), parent=self)

    def _answers(self, button: QPushButton, answer: Callable[[], object]) -> None:
        """A click on ``button`` gives the ``answer`` (emits a signal), then closes the dialog."""

        def clicked() -> None:
            answer()
            self.accept()

        button.clicked.connect(clicked)


def _info_label(text: str) -> QLabel:
    label = QLabel(text)
    label.setWordWrap(True)
    label.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
    return label


def _title_label(text: str = "") -> QLabel:
    label = QLabel(text)
    label.setObjectName("title")
    return label


class QtRoomDialog(_TabletDialog):
    """Fig. 5.5a: information about a room and what the robot can do there."""

    go_requested = Signal(int)
    request_requested = Signal(int)

    def __init__(
        self, room: Room, can_go: bool, can_request: bool, parent: QWidget | None = None
    ) -> None:
        super().__init__(parent)
        self.room = room
        self.name_label = _title_label(room.name)
        self.info_label = _info_label(room.info)
        self.go_button = QPushButton()
        self.go_button.setEnabled(can_go)
        self.request_button = QPushButton()
        self.request_button.setVisible(room.requests)
        self.request_button.setEnabled(can_request)
        self.close_button = QPushButton()
        buttons = (self.go_button, self.request_button, self.close_button)
        self._lay_out(self.name_label, self.info_label, buttons=buttons, grow=self.info_label)
        self._answers(self.go_button, lambda: self.go_requested.emit(room.id))
        self._answers(self.request_button, lambda: self.request_requested.emit(room.id))
        self.close_button.clicked.connect(self.reject)
        self.retranslate()

    def retranslate(self) -> None:
        self.setWindowTitle(self.room.name)
        self.go_button.setText(self.tr("Take me there"))
        self.request_button.setText(self.tr("Request / deliver"))
        self.close_button.setText(self.tr("Close"))


class QtRequestDialog(_TabletDialog):
    """Fig. 5.5b: the request text (typed on the on-screen keyboard) and where to deliver it."""

    HAS_KEYBOARD = True

    request_submitted = Signal(str, int, int)  # request, room, deliver_to

    def __init__(self, room: Room, plan: RoomMap, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.room = room
        self.title_label = _title_label()
        self.text_edit = QLineEdit()
        self.text_edit.setMaxLength(200)
        self.keyboard = QtKeyboard()
        self.keyboard.set_target(self.text_edit)
        self.deliver_label = QLabel()
        self.deliver_combo = QComboBox()
        self.deliver_combo.setView(QListView())  # its rows take the touch-sized style
        for other in plan.rooms:
            self.deliver_combo.addItem(other.name, other.id)
        self.send_button = QPushButton()
        self.send_button.setEnabled(False)
        self.cancel_button = QPushButton()
        self._lay_out(
            self.title_label,
            self.text_edit,
            self.keyboard,
            self.deliver_label,
            self.deliver_combo,
            buttons=(self.send_button, self.cancel_button),
        )
        self.text_edit.textChanged.connect(
            lambda text: self.send_button.setEnabled(bool(text.strip()))
        )
        self.send_button.clicked.connect(self._send)
        self.cancel_button.clicked.connect(self.reject)
        self.retranslate()

    def _send(self) -> None:
        text = self.text_edit.text().strip()
        if not text:
            return
        self.request_submitted.emit(text, self.room.id, int(self.deliver_combo.currentData()))
        self.accept()

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Request"))
        self.title_label.setText(
            self.tr("What should I ask for in %1?").replace("%1", self.room.name)
        )
        self.text_edit.setPlaceholderText(self.tr("Type your request"))
        self.deliver_label.setText(self.tr("Deliver to:"))
        self.send_button.setText(self.tr("Send"))
        self.cancel_button.setText(self.tr("Cancel"))


class QtTourStopDialog(_TabletDialog):
    """Fig. 6.2b: at a guided-tour stop, the room's information; Resume or End tour."""

    resume_requested = Signal()
    end_requested = Signal()

    def __init__(self, room: Room, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.room = room
        self.name_label = _title_label(room.name)
        self.info_label = _info_label(room.info)
        self.resume_button = QPushButton()
        self.end_button = QPushButton()
        buttons = (self.resume_button, self.end_button)
        self._lay_out(self.name_label, self.info_label, buttons=buttons, grow=self.info_label)
        self._answers(self.resume_button, self.resume_requested.emit)
        self._answers(self.end_button, self.end_requested.emit)
        self.retranslate()

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Guided tour"))
        self.resume_button.setText(self.tr("Resume tour"))
        self.end_button.setText(self.tr("End tour"))


class QtShowRequestDialog(_TabletDialog):
    """A request shown at a room: Accept / Decline, then where the robot takes it."""

    answered = Signal(int, bool)  # request id, accepted

    def __init__(self, request: ShowRequest, plan: RoomMap, parent: QWidget | None = None):
        super().__init__(parent)
        self.request = request
        self._from = plan.name(request.room)
        self._to = plan.name(request.deliver_to)
        self._accepted: bool | None = None
        self.title_label = _title_label()
        self.request_label = _info_label(request.request)
        self.request_label.setObjectName("requestText")
        self.status_label = _info_label("")
        self.accept_button = QPushButton()
        self.decline_button = QPushButton()
        self.close_button = QPushButton()
        self.close_button.setVisible(False)
        self._lay_out(
            self.title_label,
            self.request_label,
            self.status_label,
            buttons=(self.accept_button, self.decline_button, self.close_button),
            grow=self.request_label,
        )
        self.accept_button.clicked.connect(lambda: self._answer(True))
        self.decline_button.clicked.connect(lambda: self._answer(False))
        self.close_button.clicked.connect(self.accept)
        self.retranslate()

    def _answer(self, accepted: bool) -> None:
        self._accepted = accepted
        self.answered.emit(self.request.id, accepted)
        if not accepted:
            self.reject()
            return
        self.accept_button.setVisible(False)
        self.decline_button.setVisible(False)
        self.close_button.setVisible(True)
        self.retranslate()

    def set_status(self, text: str) -> None:
        """A status message from the Base Station while the dialog is open."""
        self.status_label.setText(text)

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Request"))
        self.title_label.setText(
            self.tr("A request for %1, to be delivered to %2:")
            .replace("%1", self._from)
            .replace("%2", self._to)
        )
        self.accept_button.setText(self.tr("Accept"))
        self.decline_button.setText(self.tr("Decline"))
        self.close_button.setText(self.tr("Close"))
        if self._accepted:
            self.status_label.setText(
                self.tr("Thank you! I am taking it to %1.").replace("%1", self._to)
            )


class QtHelpConfirmDialog(_TabletDialog):
    """Fig. 5.4: confirm that the robot stands at this room."""

    confirmed = Signal(int)

    def __init__(self, room: Room, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.room = room
        self.question_label = _info_label("")
        self.question_label.setObjectName("title")
        self.yes_button = QPushButton()
        self.no_button = QPushButton()
        self._lay_out(self.question_label, buttons=(self.yes_button, self.no_button))
        self._answers(self.yes_button, lambda: self.confirmed.emit(room.id))
        self.no_button.clicked.connect(self.reject)
        self.retranslate()

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Help me!"))
        self.question_label.setText(
            self.tr("Am I at %1, facing its door?").replace("%1", self.room.name)
        )
        self.yes_button.setText(self.tr("Yes, you are here"))
        self.no_button.setText(self.tr("No"))


class QtMalfunctionDialog(_TabletDialog):
    """Report a malfunction (§4.2.1.1): kind and free text (on-screen keyboard)."""

    HAS_KEYBOARD = True

    submitted = Signal(str, str)  # kind, text

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.title_label = _title_label()
        self.kind_buttons = {kind: QRadioButton() for kind in MALFUNCTION_KINDS}
        self._group = QButtonGroup(self)
        for radio in self.kind_buttons.values():
            self._group.addButton(radio)
        self.kind_buttons["collision"].setChecked(True)
        self.text_edit = QLineEdit()
        self.text_edit.setMaxLength(300)
        self.keyboard = QtKeyboard()
        self.keyboard.set_target(self.text_edit)
        self.send_button = QPushButton()
        self.cancel_button = QPushButton()
        self._lay_out(
            self.title_label,
            *self.kind_buttons.values(),
            self.text_edit,
            self.keyboard,
            buttons=(self.send_button, self.cancel_button),
        )
        self._answers(self.send_button, self._send)
        self.cancel_button.clicked.connect(self.reject)
        self.retranslate()

    def _send(self) -> None:
        kind = next(k for k, radio in self.kind_buttons.items() if radio.isChecked())
        self.submitted.emit(kind, self.text_edit.text().strip())

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Report a malfunction"))
        self.title_label.setText(self.tr("What went wrong?"))
        self.kind_buttons["collision"].setText(self.tr("Collision"))
        self.kind_buttons["wrong_position"].setText(self.tr("Wrong position"))
        self.kind_buttons["wrong_orientation"].setText(self.tr("Wrong orientation"))
        self.kind_buttons["other"].setText(self.tr("Other"))
        self.text_edit.setPlaceholderText(self.tr("Details (optional)"))
        self.send_button.setText(self.tr("Send"))
        self.cancel_button.setText(self.tr("Cancel"))
