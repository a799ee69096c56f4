"""Builders for the widget set-up every panel repeats: a button wired to what it does, and a row
or column of widgets. They only build and connect; what the widgets do stays in their panel."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from PySide6.QtWidgets import QBoxLayout, QHBoxLayout, QLayout, QPushButton, QVBoxLayout, QWidget

Item = QWidget | QLayout | tuple[QWidget | QLayout, int] | int
"""A widget or layout; ``(item, stretch)`` for one that takes a share of the spare room; a
number alone for an empty stretch of that share."""
L = TypeVar("L", bound=QBoxLayout)


def button(text: str, clicked: Callable[[], object], *, tip: str = "") -> QPushButton:
    """A push button that calls ``clicked()`` (without Qt's ``checked`` argument) on a click."""
    widget = QPushButton(text)
    widget.clicked.connect(lambda: clicked())
    if tip:
        widget.setToolTip(tip)
    return widget


def row(*items: Item, parent: QWidget | None = None) -> QHBoxLayout:
    """``items`` left to right (on ``parent`` when given)."""
    return _fill(QHBoxLayout() if parent is None else QHBoxLayout(parent), items)


def column(*items: Item, parent: QWidget | None = None) -> QVBoxLayout:
    """``items`` top to bottom (on ``parent`` when given)."""
    return _fill(QVBoxLayout() if parent is None else QVBoxLayout(parent), items)


def _fill(layout: L, items: tuple[Item, ...]) -> L:
    for item in items:
        thing, stretch = item if isinstance(item, tuple) else (item, 0)
        if isinstance(thing, int):
            layout.addStretch(thing)
        elif isinstance(thing, QLayout):
            layout.addLayout(thing, stretch)
        else:
            layout.addWidget(thing, stretch)
    return layout
