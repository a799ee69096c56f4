"""A speedometer dial (thesis §4.2.2.1: the station "shows current speeds").

A 240-degree arc from ``-maximum`` to ``+maximum`` with a needle at the value and the value in
text below; the value is clamped to the dial for the needle only.
"""

from __future__ import annotations

import math

from PySide6.QtCore import QPointF, QRectF, QSize, Qt
from PySide6.QtGui import QColor, QPainter, QPaintEvent, QPen
from PySide6.QtWidgets import QSizePolicy, QWidget

SWEEP_DEG = 240.0


class QtSpeedometer(QWidget):
    """Dial showing ``value`` in ``unit`` between ``-maximum`` and ``+maximum``."""

    def __init__(
        self, title: str, unit: str, maximum: float, parent: QWidget | None = None
    ) -> None:
        super().__init__(parent)
        self._title = title
        self._unit = unit
        self._maximum = maximum
        self.value = 0.0
        self.setMinimumSize(120, 110)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Preferred)

    def set_value(self, value: float) -> None:
        if value != self.value:
            self.value = value
            self.update()

    def sizeHint(self) -> QSize:
        return QSize(160, 130)

    def needle_angle_deg(self) -> float:
        """Needle angle, degrees counter-clockwise from +x (90 = straight up at zero)."""
        frac = max(-1.0, min(1.0, self.value / self._maximum))
        return 90.0 - frac * SWEEP_DEG / 2.0

    def paintEvent(self, event: QPaintEvent) -> None:
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        w, h = self.width(), self.height()
        r = max(10.0, min(w / 2.0, h * 0.55) - 8.0)
        c = QPointF(w / 2.0, r + 6.0)
        rect = QRectF(c.x() - r, c.y() - r, 2 * r, 2 * r)
        painter.setPen(QPen(QColor(90, 90, 90), 6))
        start = 90.0 - SWEEP_DEG / 2.0
        painter.drawArc(rect, int(start * 16), int(SWEEP_DEG * 16))
        painter.setPen(QPen(QColor(160, 160, 160), 2))
        for k in range(-2, 3):
            a = math.radians(90.0 - k * SWEEP_DEG / 4.0)
            p1 = QPointF(c.x() + 0.8 * r * math.cos(a), c.y() - 0.8 * r * math.sin(a))
            p2 = QPointF(c.x() + r * math.cos(a), c.y() - r * math.sin(a))
            painter.drawLine(p1, p2)
        a = math.radians(self.needle_angle_deg())
        painter.setPen(QPen(QColor(200, 30, 30), 4))
        painter.drawLine(c, QPointF(c.x() + 0.9 * r * math.cos(a), c.y() - 0.9 * r * math.sin(a)))
        painter.setPen(QColor(20, 20, 20))
        text_rect = QRectF(0, c.y() + 0.25 * r, w, h - c.y() - 0.25 * r)
        painter.drawText(
            text_rect,
            Qt.AlignmentFlag.AlignHCenter | Qt.AlignmentFlag.AlignTop,
            f"{self._title}\n{self.value:+.2f} {self._unit}",
        )
        painter.end()
