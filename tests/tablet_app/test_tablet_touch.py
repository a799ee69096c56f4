"""Touch targets of at least 9 mm on both tablet screens, and typing on the on-screen keyboard.

Sizes are measured on the real widgets of every screen and dialog, at each tablet's real dots
per inch (a 10.1-inch 1280 x 800 panel is 149 dpi, the Nexus 10's 2560 x 1600 is 299 dpi; the
offscreen platform itself reports 96).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QAbstractButton, QComboBox, QDialog, QLineEdit, QRadioButton, QWidget

from interbot_core.protocol import GoalStatus, Localisation, ShowRequest, TourState

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")

TABLETS = {"1280x800": (1280, 800, 149.0), "2560x1600": (2560, 1600, 299.0)}


def click(widget: Any) -> None:
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)


def too_small(window: Any, min_px: float) -> list[str]:
    roots: list[QWidget] = [window]
    if isinstance(window.dialog, QDialog):
        roots.append(window.dialog)
    small = []
    for root in roots:
        for w in root.findChildren(QWidget):
            if not w.isVisible() or (not w.isEnabled() and not isinstance(w, QAbstractButton)):
                continue
            if isinstance(w, QRadioButton):
                size = w.height()  # the whole row is the target
            elif isinstance(w, QAbstractButton | QComboBox | QLineEdit):
                size = min(w.width(), w.height())
            else:
                continue
            if size < min_px - 0.5:
                small.append(f"{type(w).__name__} {w.objectName() or w.text()!r}: {size} px")
    return small


def _rooms(window: Any, station: Any) -> None:
    window.show_map()


def _request(window: Any, station: Any) -> None:
    window.show_map()
    click(window.map_view.room_button(3))
    click(window.dialog.request_button)


SCREENS: dict[str, Callable[[Any, Any], None]] = {
    "menu": lambda w, s: w.show_menu(),
    "joystick": lambda w, s: w.show_joystick(),
    "map": _rooms,
    "help": lambda w, s: (w.show_map(), s.send(Localisation("lost"))),
    "room dialog": lambda w, s: (w.show_map(), click(w.map_view.room_button(4))),
    "request dialog": _request,
    "malfunction dialog": lambda w, s: click(w.menu.malfunction_button),
    "motion bar": lambda w, s: (w.go_to(4), s.send(GoalStatus(4, False, False))),
    "tour stop": lambda w, s: (
        s.send(TourState((0, 3), (0,), 3)),
        s.send(GoalStatus(3, True, True)),
    ),
    "request shown": lambda w, s: s.send(ShowRequest(9, "a pen", 4, 0)),
}


@pytest.mark.parametrize("tablet", TABLETS)
@pytest.mark.parametrize("screen", SCREENS)
def test_every_target_is_at_least_9_mm(
    qtbot: Any, station: Any, window: Any, tablet: str, screen: str
) -> None:
    width, height, dpi = TABLETS[tablet]
    window.dpi_override = dpi
    window.resize(width, height)
    window.apply_metrics()
    SCREENS[screen](window, station)
    QTest.qWait(150)
    min_px = 9.0 / 25.4 * dpi
    assert too_small(window, min_px) == []


@pytest.mark.qt_log_ignore(
    "propagateSizeHints", "does not support raise", "does not support grabbing"
)
@pytest.mark.parametrize("tablet", TABLETS)
def test_dropdown_rows_are_finger_sized(qtbot: Any, station: Any, window: Any, tablet: str) -> None:
    width, height, dpi = TABLETS[tablet]
    window.dpi_override = dpi
    window.resize(width, height)
    window.apply_metrics()
    _request(window, station)
    combo = window.dialog.deliver_combo
    combo.showPopup()
    view = combo.view()
    qtbot.waitUntil(view.isVisible)
    rows = [view.visualRect(combo.model().index(i, 0)).height() for i in range(combo.count())]
    combo.hidePopup()
    assert min(rows) >= 9.0 / 25.4 * dpi - 0.5, rows


def test_request_typed_on_the_on_screen_keyboard(qtbot: Any, station: Any, window: Any) -> None:
    _request(window, station)
    dialog = window.dialog
    keys = dialog.keyboard.keys
    for name in ("shift", "c", "a", "f", "é", "space", "x", "backspace"):
        click(keys[name])
    assert dialog.text_edit.text() == "Café "
    assert dialog.text_edit.hasFocus() or not dialog.keyboard.keys["c"].hasFocus()
    click(dialog.send_button)
    qtbot.waitUntil(lambda: bool(station.messages("requestFrom") or station.messages("request")))
