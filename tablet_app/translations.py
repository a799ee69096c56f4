"""Run-time language switch of the Tablet (English source strings, Portuguese translation).

Every visible string goes through ``self.tr()``; `LanguageSwitcher` installs or removes the
compiled `resources/translations/tablet_<lang>.qm` and Qt then sends ``LanguageChange`` to every
widget, whose ``changeEvent`` calls ``retranslate()``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PySide6.QtCore import QCoreApplication, QEvent, QObject, QTranslator

logger = logging.getLogger(__name__)

TRANSLATIONS_DIR = Path(__file__).resolve().parent.parent / "resources" / "translations"
LANGUAGES = ("en", "pt")


class LanguageSwitcher(QObject):
    """Holds the installed translator; ``set_language("pt")`` / ``("en")``."""

    def __init__(self, directory: Path = TRANSLATIONS_DIR, parent: QObject | None = None):
        super().__init__(parent)
        self._directory = directory
        self._translator: QTranslator | None = None
        self.language = "en"

    def set_language(self, language: str) -> bool:
        """Switch the UI language; False (and English) when the translation is missing."""
        if language not in LANGUAGES:
            raise ValueError(f"language must be one of {', '.join(LANGUAGES)}, got {language!r}")
        app = QCoreApplication.instance()
        if app is None:
            raise RuntimeError("create the QApplication before switching languages")
        if self._translator is not None:
            app.removeTranslator(self._translator)
            self._translator = None
        self.language = "en"
        if language == "en":
            return True
        translator = QTranslator(self)
        path = self._directory / f"tablet_{language}.qm"
        if not translator.load(str(path)):
            logger.warning("translation %s not found; staying in English", path)
            return False
        app.installTranslator(translator)
        self._translator = translator
        self.language = language
        return True


class Retranslated:
    """Mixin of a widget (listed before its Qt class): ``retranslate()`` sets every visible
    string, and runs again on each ``LanguageChange``."""

    def retranslate(self) -> None:
        raise NotImplementedError

    def changeEvent(self, event: QEvent) -> None:
        if event.type() == QEvent.Type.LanguageChange:
            self.retranslate()
        super().changeEvent(event)  # type: ignore[misc]
