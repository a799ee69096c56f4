"""QtJoystick: touch and mouse give eqs. 5.1/5.2, clamped to the circle, zero on release."""

from __future__ import annotations

from typing import Any

import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtTest import QTest

from interbot_core.joystick import joystick_command
from interbot_qt.qt_joystick import QtJoystick

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")


@pytest.fixture
def joystick(qtbot: Any) -> QtJoystick:
    widget = QtJoystick(linear_max=0.5, angular_max=1.0)
    qtbot.addWidget(widget)
    widget.resize(400, 300)
    widget.show()
    qtbot.waitExposed(widget)
    return widget


def touch(widget: Any, device: Any, action: str, point: QPoint) -> None:
    # Through the QWindow: QTest's widget overload ignores the window's (2, 2) offscreen offset.
    sequence = QTest.touchEvent(widget.window().windowHandle(), device, autoCommit=False)
    getattr(sequence, action)(0, widget.mapTo(widget.window(), point))
    sequence.commit()


def expected(joystick: QtJoystick, point: QPoint) -> tuple[float, float]:
    c = joystick.center()
    return joystick_command(c.x(), c.y(), point.x(), point.y(), joystick.radius(), 0.5, 1.0)


def test_geometry_follows_the_widget(joystick: QtJoystick) -> None:
    assert (joystick.center().x(), joystick.center().y()) == (200.0, 150.0)
    assert joystick.radius() == pytest.approx(150.0 - 300 * QtJoystick.MARGIN_FRACTION)


def test_touch_inside_outside_and_release(qtbot: Any, joystick: QtJoystick) -> None:
    device = QTest.createTouchDevice()
    speeds: list[tuple[float, float]] = []
    joystick.speed_changed.connect(lambda lin, ang: speeds.append((lin, ang)))
    top = QPoint(200, 150 - round(joystick.radius()))
    with qtbot.waitSignal(joystick.pressed):
        touch(joystick, device, "press", top)
    assert speeds[-1] == pytest.approx((0.5, 0.0))  # full forward, no turn
    left = QPoint(200 - round(joystick.radius() / 2), 150)
    touch(joystick, device, "move", left)
    assert speeds[-1] == pytest.approx((0.0, 0.5))  # half left turn, CCW positive
    corner = QPoint(399, 299)  # outside the circle: clamped radially to the edge
    touch(joystick, device, "move", corner)
    assert speeds[-1] == pytest.approx(expected(joystick, corner))
    linear, angular = speeds[-1]
    assert (linear / 0.5) ** 2 + (angular / 1.0) ** 2 == pytest.approx(1.0)
    assert linear < 0 and angular < 0  # backwards, turning right
    with qtbot.waitSignal(joystick.released):
        touch(joystick, device, "release", corner)
    assert speeds[-1] == (0.0, 0.0)
    assert not joystick.state.pressed


def test_mouse_press_drag_release(qtbot: Any, joystick: QtJoystick) -> None:
    speeds: list[tuple[float, float]] = []
    joystick.speed_changed.connect(lambda lin, ang: speeds.append((lin, ang)))
    point = QPoint(250, 100)
    QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=point)
    assert speeds == [pytest.approx(expected(joystick, point))]
    QTest.mouseRelease(joystick, Qt.MouseButton.LeftButton, pos=point)
    assert speeds[-1] == (0.0, 0.0)


def test_new_limits_re_emit_while_held(qtbot: Any, joystick: QtJoystick) -> None:
    speeds: list[tuple[float, float]] = []
    joystick.speed_changed.connect(lambda lin, ang: speeds.append((lin, ang)))
    top = QPoint(200, 150 - round(joystick.radius()))
    QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=top)
    joystick.set_limits(1.0, 2.0)
    assert speeds[-1] == pytest.approx((1.0, 0.0))
    QTest.mouseRelease(joystick, Qt.MouseButton.LeftButton, pos=top)


def test_hiding_a_held_joystick_releases_it(qtbot: Any, joystick: QtJoystick) -> None:
    QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=QPoint(200, 60))
    with qtbot.waitSignal(joystick.released):
        joystick.hide()
    assert joystick.command() == (0.0, 0.0)
