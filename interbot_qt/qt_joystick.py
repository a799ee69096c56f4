"""Virtual touch joystick widget (thesis §5.2.2.3, Fig. 5.7, eqs. 5.1 and 5.2).

    linear_vel  = (center_Y - pressed_Y) / radius * linear_max       (5.1)
    angular_vel = (center_X - pressed_X) / radius * angular_max      (5.2)

The white circle fills the widget's shorter side (minus a margin). Every point inside it maps
to a (linear [m/s], angular [rad/s]) command; a point outside is clamped radially onto the edge;
releasing gives zero. The mathematics is `interbot_core.joystick.JoystickState`; this widget only
turns touch (`QTouchEvent`, thesis: "QTouchEvent ... emits information about touched points")
and mouse events into its press/move/release calls and paints the result, so the same widget
serves the Tablet (touch) and the Base Station (mouse), as §4.2 asks.
"""

from __future__ import annotations

import logging
import math

from PySide6.QtCore import QEvent, QPointF, QRectF, QSize, Qt, Signal
from PySide6.QtGui import QColor, QMouseEvent, QPainter, QPaintEvent, QPen, QResizeEvent
from PySide6.QtWidgets import QSizePolicy, QWidget

from interbot_core.joystick import JoystickState

logger = logging.getLogger(__name__)

_TOUCH_EVENTS = (QEvent.Type.TouchBegin, QEvent.Type.TouchUpdate, QEvent.Type.TouchEnd)


class QtJoystick(QWidget):
    """A circle that turns a touch or mouse press into (linear, angular) velocities.

    Signals: ``speed_changed(linear [m/s], angular [rad/s])`` on every press, move, release and
    limit change while pressed; ``pressed()`` and ``released()`` around a touch.
    """

    speed_changed = Signal(float, float)
    pressed = Signal()
    released = Signal()

    MARGIN_FRACTION = 0.06  # of the shorter side, between the circle and the widget edge

    def __init__(
        self, linear_max: float = 0.5, angular_max: float = 1.0, parent: QWidget | None = None
    ) -> None:
        super().__init__(parent)
        self.setAttribute(Qt.WidgetAttribute.WA_AcceptTouchEvents, True)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setMinimumSize(120, 120)
        self.state = JoystickState(60.0, 60.0, 50.0, linear_max, angular_max)
        self._knob: QPointF | None = None  # widget position of the (clamped) press
        self._update_geometry()

    # ---------------------------------------------------------------- public API
    def command(self) -> tuple[float, float]:
        """The current (linear [m/s], angular [rad/s]); zero when not pressed."""
        return self.state.command

    def center(self) -> QPointF:
        return QPointF(self.width() / 2.0, self.height() / 2.0)

    def radius(self) -> float:
        """Radius of the white circle [px]."""
        side = min(self.width(), self.height())
        return max(1.0, side / 2.0 - side * self.MARGIN_FRACTION)

    def set_limits(self, linear_max: float, angular_max: float) -> None:
        """New maximum speeds [m/s], [rad/s]; a held joystick re-emits its command."""
        command = self.state.set_limits(linear_max, angular_max)
        if self.state.pressed:
            self.speed_changed.emit(*command)
        self.update()

    def sizeHint(self) -> QSize:
        return QSize(400, 400)

    # ---------------------------------------------------------------- input
    def _press(self, pos: QPointF) -> None:
        was_pressed = self.state.pressed
        command = self.state.press(pos.x(), pos.y())
        self._knob = self._clamped(pos)
        if not was_pressed:
            self.pressed.emit()
        self.speed_changed.emit(*command)
        self.update()

    def _release(self) -> None:
        if not self.state.pressed:
            return
        command = self.state.release()
        self._knob = None
        self.speed_changed.emit(*command)
        self.released.emit()
        self.update()

    def _clamped(self, pos: QPointF) -> QPointF:
        c = self.center()
        dx, dy = pos.x() - c.x(), pos.y() - c.y()
        r = self.radius()
        d = math.hypot(dx, dy)
        if d > r:
            dx, dy = dx * r / d, dy * r / d
        return QPointF(c.x() + dx, c.y() + dy)

    def event(self, event: QEvent) -> bool:
        if event.type() in _TOUCH_EVENTS:
            points = event.points()  # type: ignore[attr-defined]
            if event.type() == QEvent.Type.TouchEnd or not points:
                self._release()
            else:
                # The first finger drives; others are ignored (one joystick, one finger).
                self._press(points[0].position())
            event.accept()
            return True
        if event.type() == QEvent.Type.TouchCancel:
            self._release()
            event.accept()
            return True
        return super().event(event)

    def mousePressEvent(self, event: QMouseEvent) -> None:
        if event.button() == Qt.MouseButton.LeftButton:
            self._press(event.position())
            event.accept()

    def mouseMoveEvent(self, event: QMouseEvent) -> None:
        if self.state.pressed and event.buttons() & Qt.MouseButton.LeftButton:
            self._press(event.position())
            event.accept()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:
        if event.button() == Qt.MouseButton.LeftButton:
            self._release()
            event.accept()

    def hideEvent(self, event: QEvent) -> None:
        # A joystick that disappears while held must not keep the robot moving.
        self._release()
        super().hideEvent(event)  # type: ignore[arg-type]

    # ---------------------------------------------------------------- geometry and painting
    def _update_geometry(self) -> None:
        c = self.center()
        self.state.set_geometry(c.x(), c.y(), self.radius())

    def resizeEvent(self, event: QResizeEvent) -> None:
        self._update_geometry()
        super().resizeEvent(event)

    def paintEvent(self, event: QPaintEvent) -> None:
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        painter.fillRect(self.rect(), QColor(20, 20, 20))
        c, r = self.center(), self.radius()
        painter.setPen(QPen(QColor(200, 200, 200), max(2.0, r / 100.0)))
        painter.setBrush(QColor(250, 250, 250))
        painter.drawEllipse(c, r, r)
        axis_pen = QPen(QColor(150, 150, 150), max(1.0, r / 150.0), Qt.PenStyle.DashLine)
        painter.setPen(axis_pen)
        painter.drawLine(QPointF(c.x() - r, c.y()), QPointF(c.x() + r, c.y()))
        painter.drawLine(QPointF(c.x(), c.y() - r), QPointF(c.x(), c.y() + r))
        knob = self._knob if self._knob is not None else c
        knob_r = max(12.0, r * 0.18)
        painter.setPen(QPen(QColor(30, 30, 30), max(2.0, r / 120.0)))
        painter.setBrush(QColor(30, 110, 220) if self._knob is not None else QColor(120, 120, 120))
        painter.drawEllipse(QRectF(knob.x() - knob_r, knob.y() - knob_r, 2 * knob_r, 2 * knob_r))
        painter.end()
