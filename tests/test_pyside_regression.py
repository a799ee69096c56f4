"""Regression guard for PySide6 6.12.0 on CPython 3.11 (shared/FIELD_NOTES.md).

That release drops a reference to None on every call of a void Qt method and to True on every
Python-side Signal.emit(); the interpreter aborts after a few thousand calls. These loops run far
past that point, so an upgrade that brings the bug back kills this test process.
"""

from __future__ import annotations

import sys

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtWidgets import QApplication


class _Emitter(QObject):
    fired = Signal(bool)


def test_none_refcount_survives_void_calls(qapp: QApplication) -> None:
    before = sys.getrefcount(None)
    timer = QTimer()
    for i in range(100_000):
        timer.setInterval(i % 50 + 1)
    assert timer.interval() == 99_999 % 50 + 1
    # A leak of one reference per call would show as a drop of ~10^5 (or a crash).
    assert sys.getrefcount(None) > before - 1000


def test_true_refcount_survives_emits(qapp: QApplication) -> None:
    emitter = _Emitter()
    received: list[bool] = []
    emitter.fired.connect(received.append)
    before = sys.getrefcount(True)
    for _ in range(10_000):
        emitter.fired.emit(True)
    assert len(received) == 10_000
    assert sys.getrefcount(True) > before - 1000


def test_pyqtgraph_frames(qapp: QApplication) -> None:
    widget = pg.PlotWidget()
    curve = widget.plot()
    rng = np.random.default_rng(0)
    for _ in range(400):
        curve.setData(rng.normal(size=1081))
        qapp.processEvents()
    assert curve.getData()[1] is not None
    widget.close()
    widget.deleteLater()
