"""An on-screen keyboard for the tablet's text fields (a kiosk has no physical keyboard).

Qt Virtual Keyboard is not in the PySide6-Essentials wheel (it is a QML add-on), so this is a
plain widget: rows of finger-sized keys (the window's style sheet gives every button at least
the 9 mm touch target), Portuguese letters included (ç and the accented vowels), a one-shot
Shift, Backspace and Space. Keys never take the focus, so the text field keeps its cursor; each
tap inserts at the cursor of the field given to `set_target`.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QGridLayout, QLineEdit, QPushButton, QSizePolicy, QWidget

from tablet_app.translations import Retranslated

ROWS: tuple[str, ...] = (
    "1234567890",
    "qwertyuiop",
    "asdfghjklç",
    "zxcvbnm,.?",
    "áéíóúãõâêà",
)
SHIFT, BACKSPACE, SPACE = "shift", "backspace", "space"


class QtKeyboard(Retranslated, QWidget):
    """Letter keys in `ROWS` and a bottom row of Shift, Space and Backspace."""

    key_tapped = Signal(str)  # the text inserted, or "backspace"

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._target: QLineEdit | None = None
        self._shift = False
        self.keys: dict[str, QPushButton] = {}
        grid = QGridLayout(self)
        grid.setSpacing(4)
        grid.setContentsMargins(0, 0, 0, 0)
        for r, row in enumerate(ROWS):
            for c, char in enumerate(row):
                self._add_key(grid, char, r, c)
        bottom = len(ROWS)
        self._add_key(grid, SHIFT, bottom, 0, span=2)
        self._add_key(grid, SPACE, bottom, 2, span=6)
        self._add_key(grid, BACKSPACE, bottom, 8, span=2)
        self.keys[SHIFT].setCheckable(True)
        self.retranslate()

    def _add_key(self, grid: QGridLayout, name: str, row: int, col: int, span: int = 1) -> None:
        key = QPushButton(name if len(name) == 1 else "")
        key.setObjectName(f"key_{name}")
        key.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        key.setAutoRepeat(name == BACKSPACE)
        key.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        key.clicked.connect(lambda _checked=False, n=name: self._tap(n))
        grid.addWidget(key, row, col, 1, span)
        self.keys[name] = key

    def set_target(self, line_edit: QLineEdit) -> None:
        self._target = line_edit

    def _tap(self, name: str) -> None:
        if name == SHIFT:
            self._set_shift(not self._shift)
            return
        target = self._target
        if name == BACKSPACE:
            if target is not None:
                target.backspace()
            self.key_tapped.emit(BACKSPACE)
            return
        text = " " if name == SPACE else (name.upper() if self._shift else name)
        if target is not None:
            target.insert(text)
        self._set_shift(False)
        self.key_tapped.emit(text)

    def _set_shift(self, on: bool) -> None:
        self._shift = on
        self.keys[SHIFT].setChecked(on)
        for name, key in self.keys.items():
            if len(name) == 1:
                key.setText(name.upper() if on else name)

    def retranslate(self) -> None:
        self.keys[SHIFT].setText("⇧ " + self.tr("Shift"))
        self.keys[SPACE].setText(self.tr("Space"))
        self.keys[BACKSPACE].setText("⌫")
