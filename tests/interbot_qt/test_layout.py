"""The panel builders: a button calls its action with no arguments; rows and columns keep the
order and the stretch they are given."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QLabel, QWidget

from interbot_qt.layout import button, column, row


def test_a_button_calls_its_action_without_qts_checked_flag(qtbot) -> None:
    calls: list[tuple[object, ...]] = []
    widget = button("Go", lambda *args: calls.append(args), tip="go there")
    qtbot.addWidget(widget)
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)
    assert calls == [()] and widget.text() == "Go" and widget.toolTip() == "go there"


def test_rows_and_columns_keep_order_and_stretch(qtbot) -> None:
    host = QWidget()
    qtbot.addWidget(host)
    a, b, c = QLabel("a"), QLabel("b"), QLabel("c")
    inner = row(b, (c, 3))
    outer = column(a, 2, (inner, 1), parent=host)
    assert host.layout() is outer
    assert [outer.stretch(i) for i in range(outer.count())] == [0, 2, 1]
    assert outer.itemAt(0).widget() is a and outer.itemAt(1).spacerItem() is not None
    assert outer.itemAt(2).layout() is inner
    assert [inner.itemAt(i).widget() for i in range(2)] == [b, c] and inner.stretch(1) == 3
