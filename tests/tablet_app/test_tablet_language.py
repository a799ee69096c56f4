"""Every string on every tablet screen changes when the language is Portuguese.

The test walks each screen or dialog with real clicks and station messages in English and reads
every visible text (labels, buttons, titles, list items, the map's painted room names), then
switches to Portuguese with the real compiled catalogue, walks the same way again and fails on
any text that stayed English: a string without ``tr()``, a catalogue entry left unfinished, a
room name without ``name_pt``. (Dialogs are modal and the language buttons are on the main
menu, so a dialog is always opened in the language it is read in.)
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QAbstractButton, QComboBox, QDialog, QGroupBox, QLabel, QWidget

from interbot_core.protocol import (
    GoalStatus,
    Localisation,
    ShowRequest,
    StatusInfo,
    TourState,
)

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")

# Texts that are the same in both languages: numbers, addresses, the robot's name, user input.
SAME = re.compile(r"^[\d\s.:·%/,()#?+−-]*(ms|m|s|m/s|rad/s)?[\d\s.:·%/,()#?+-]*$")
# Words that are the same in Portuguese, and the language buttons (each in its own language).
SAME_WORDS = {"Interbot", "OK", "Bar", "Joystick", "Menu", "English", "Português", "⌫"}
USER_TEXT = {"sign this form"}


def click(widget: Any) -> None:
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)


def _path(widget: QWidget, root: QWidget) -> str:
    """Where ``widget`` sits under ``root``: the same on every run of the same screen."""
    parts = []
    w = widget
    while w is not None and w is not root:
        parent = w.parentWidget()
        siblings = [] if parent is None else [c for c in parent.children() if type(c) is type(w)]
        parts.append(f"{type(w).__name__}{siblings.index(w) if w in siblings else 0}")
        w = parent
    return type(root).__name__ + "/" + "/".join(reversed(parts))


def visible_texts(window: Any) -> dict[str, tuple[str, str]]:
    """``{path: (class, text)}`` of every visible text in the window and its dialog."""
    roots: list[QWidget] = [window]
    if isinstance(window.dialog, QDialog):
        roots.append(window.dialog)
    found: dict[str, tuple[str, str]] = {}
    for root in roots:
        widgets = [root, *root.findChildren(QWidget)]
        for w in widgets:
            if not w.isVisible():
                continue
            texts: list[str] = []
            if isinstance(w, QLabel | QAbstractButton):
                texts.append(w.text())
            if isinstance(w, QGroupBox):
                texts.append(w.title())
            if isinstance(w, QComboBox):
                texts.extend(w.itemText(i) for i in range(w.count()))
            if w.isWindow():
                texts.append(w.windowTitle())
            text = " | ".join(t for t in texts if t)
            if text:
                found[_path(w, root)] = (type(w).__name__, text)
    for room in window.shown_plan.rooms:  # room names are painted, not widgets
        found[f"room {room.id}"] = ("room", room.name)
    return found


def english_leftovers(
    qtbot: Any, station: Any, window: Any, walk: Callable[[Any, Any, Any], None]
) -> list[str]:
    walk(qtbot, station, window)
    english = visible_texts(window)
    if window.dialog is not None:
        window.dialog.close()
    window.session.on_localisation(Localisation("ok"))
    window.session.on_connected()  # as after a station restart: a clean slate
    assert window.languages.set_language("pt")
    try:
        QTest.qWait(20)  # LanguageChange reaches every widget
        walk(qtbot, station, window)
        portuguese = visible_texts(window)
    finally:
        window.languages.set_language("en")  # the translator is the application's
    left = []
    for key, (kind, text) in english.items():
        if SAME.match(text) or text in USER_TEXT or text in SAME_WORDS or len(text) == 1:
            continue
        if key in portuguese and portuguese[key][1] == text:
            left.append(f"{kind}: {text!r}")
    assert len(portuguese) >= 0.8 * len(english), "the Portuguese walk did not reach the screen"
    return left


def _menu(qtbot: Any, station: Any, window: Any) -> None:
    window.show_menu()


def _joystick(qtbot: Any, station: Any, window: Any) -> None:
    window.show_joystick()


def _map_lost(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    station.send(Localisation("lost"))
    qtbot.waitUntil(lambda: window.map_screen.help_banner.isVisible())


def _helping(qtbot: Any, station: Any, window: Any) -> None:
    _map_lost(qtbot, station, window)
    click(window.map_screen.help_button)
    click(window.map_view.room_button(4))


def _room_dialog(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    click(window.map_view.room_button(3))


def _request_dialog(qtbot: Any, station: Any, window: Any) -> None:
    _room_dialog(qtbot, station, window)
    click(window.dialog.request_button)


def _going(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    window.go_to(4)
    station.send(GoalStatus(4, False, False))
    station.send(StatusInfo("Office", "navigating, 12.0 m to the next goal"))
    qtbot.waitUntil(lambda: window.motion_bar.isVisible() and "12" in window.activity_label.text())


def _arrived(qtbot: Any, station: Any, window: Any) -> None:
    _going(qtbot, station, window)
    station.send(GoalStatus(4, True, False))
    qtbot.waitUntil(lambda: not window.motion_bar.isVisible())


def _tour_stop(qtbot: Any, station: Any, window: Any) -> None:
    window.show_map()
    station.send(TourState((0, 3, 4), (0,), 3))
    station.send(GoalStatus(3, True, True))
    qtbot.waitUntil(lambda: window.dialog is not None)


def _show_request(qtbot: Any, station: Any, window: Any) -> None:
    station.send(ShowRequest(9, "sign this form", 4, 0))
    qtbot.waitUntil(lambda: window.dialog is not None)


def _malfunction(qtbot: Any, station: Any, window: Any) -> None:
    click(window.menu.malfunction_button)


SCREENS: dict[str, Callable[[Any, Any, Any], None]] = {
    "menu": _menu,
    "joystick": _joystick,
    "map, robot lost": _map_lost,
    "help: confirm a room": _helping,
    "room dialog": _room_dialog,
    "request dialog": _request_dialog,
    "going somewhere": _going,
    "arrived": _arrived,
    "tour stop": _tour_stop,
    "request shown": _show_request,
    "malfunction report": _malfunction,
}


@pytest.mark.parametrize("screen", SCREENS)
def test_no_english_left_on_screen(qtbot: Any, station: Any, window: Any, screen: str) -> None:
    assert english_leftovers(qtbot, station, window, SCREENS[screen]) == []


def test_catalogue_is_complete_and_compiled() -> None:
    """Every source string has a finished Portuguese translation, and the .qm is not older."""
    import xml.etree.ElementTree as ET

    from tablet_app.translations import TRANSLATIONS_DIR

    ts = TRANSLATIONS_DIR / "tablet_pt.ts"
    unfinished = [
        m.findtext("source")
        for m in ET.parse(ts).getroot().iter("message")
        if (t := m.find("translation")) is None or t.get("type") or not (t.text or "").strip()
    ]
    assert unfinished == []
    qm = TRANSLATIONS_DIR / "tablet_pt.qm"
    assert qm.stat().st_size > 1000


def test_an_outcome_already_shown_changes_language_with_its_room_name(
    qtbot: Any, station: Any, window: Any
) -> None:
    _arrived(qtbot, station, window)
    assert window.status_label.text() == "Arrived at Office."
    assert window.languages.set_language("pt")
    try:
        qtbot.waitUntil(lambda: window.status_label.text() == "Cheguei a Gabinete.")
    finally:
        window.languages.set_language("en")


def test_the_robot_turning_to_find_itself_is_said_in_both_languages(qapp: Any) -> None:
    """Issue 16: the robot reports ``turning`` while a search turns it in place; the tablet
    says so (not only "Finding my position…"), in English and Portuguese."""
    from interbot_core.protocol import Localisation
    from tablet_app.tablet_session import TabletSession
    from tablet_app.texts import activity_text
    from tablet_app.translations import LanguageSwitcher

    session = TabletSession(room_xy=lambda room: None, home_room=0)
    session.on_connected()
    session.on_localisation(Localisation("searching"))
    assert activity_text(str, session) == "Finding my position…"
    session.on_localisation(Localisation("turning"))
    assert activity_text(str, session) == "Turning to find my position…"
    assert not session.lost  # no "Help me!" while it is still finding itself
    languages = LanguageSwitcher()
    assert languages.set_language("pt")
    try:
        assert activity_text(str, session) == "A rodar para encontrar a minha posição…"
    finally:
        languages.set_language("en")
