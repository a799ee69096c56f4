"""Virtual touch joystick: screen point to velocity command (thesis §5.2.2.3, eqs. 5.1 and 5.2).

    linear_vel  = (center_Y - pressed_Y) / radius * linear_max       (5.1)
    angular_vel = (center_X - pressed_X) / radius * angular_max      (5.2)

Screen coordinates [px]: x grows right, y grows down. So pressing above the centre drives
forward (positive linear) and pressing left of the centre turns left, which is a positive
(counter-clockwise) angular velocity in REP-103. A point outside the circle is moved radially
onto its edge (thesis: "the speed command relative to the outer edge of the white circle"), so
the normalised command ``(linear/linear_max, angular/angular_max)`` never has a norm above 1.
Releasing the touch commands zero.
"""

from __future__ import annotations

import logging
import math
from typing import Annotated, ClassVar

from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)


class JoystickError(ValueError):
    """Invalid joystick geometry or limits."""


Pixels = Annotated[float, Meta(ge=-schema.FINITE, le=schema.FINITE, extra={"unit": "px"})]


def _at_least(low: float, unit: str) -> Meta:
    return Meta(ge=low, le=schema.FINITE, extra={"unit": unit})


# Built only to check arguments (`schema.Declared`): a bad value raises JoystickError naming it.
class _Geometry(schema.Declared, frozen=True):
    ROOT: ClassVar[str] = "joystick"
    ERROR: ClassVar[type[Exception]] = JoystickError
    center_x: Pixels
    center_y: Pixels
    radius: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "px"})]


class _Limits(schema.Declared, frozen=True):
    ROOT: ClassVar[str] = "joystick"
    ERROR: ClassVar[type[Exception]] = JoystickError
    linear_max: Annotated[float, _at_least(0.0, "m/s")]
    angular_max: Annotated[float, _at_least(0.0, "rad/s")]


class _Pressed(schema.Declared, frozen=True):
    ROOT: ClassVar[str] = "joystick.pressed"
    ERROR: ClassVar[type[Exception]] = JoystickError
    x: Pixels
    y: Pixels


def _clamp_unit(value: float) -> float:
    return min(1.0, max(-1.0, value))


def joystick_command(
    center_x: float,
    center_y: float,
    pressed_x: float,
    pressed_y: float,
    radius: float,
    linear_max: float,
    angular_max: float,
) -> tuple[float, float]:
    """Eqs. 5.1/5.2: (linear [m/s], angular [rad/s]) for a press at (pressed_x, pressed_y) [px].

    ``linear = (center_y - pressed_y) / radius * linear_max`` and
    ``angular = (center_x - pressed_x) / radius * angular_max``, with the pressed point first
    clamped radially onto the circle of ``radius`` around the centre.
    """
    _Geometry(center_x, center_y, radius)
    _Limits(linear_max, angular_max)
    _Pressed(pressed_x, pressed_y)
    u = (center_x - pressed_x) / radius  # + when pressed left of centre: turn left
    v = (center_y - pressed_y) / radius  # + when pressed above centre: forward
    norm = math.hypot(u, v)
    if norm > 1.0:
        u, v = u / norm, v / norm
    # Rounding can leave an axis a few ulps above 1; the command must never exceed the maxima.
    return _clamp_unit(v) * linear_max, _clamp_unit(u) * angular_max


class JoystickState:
    """Press / move / release of one touch on the joystick; each returns the command to send.

    The geometry (centre, radius [px]) follows the widget's size; the maxima follow the sliders.
    A move without a press is ignored (command stays zero).
    """

    def __init__(
        self,
        center_x: float,
        center_y: float,
        radius: float,
        linear_max: float,
        angular_max: float,
    ) -> None:
        _Geometry(center_x, center_y, radius)
        _Limits(linear_max, angular_max)
        self._center = (float(center_x), float(center_y))
        self._radius = float(radius)
        self.linear_max = float(linear_max)
        self.angular_max = float(angular_max)
        self._pressed_at: tuple[float, float] | None = None

    @property
    def pressed(self) -> bool:
        return self._pressed_at is not None

    @property
    def command(self) -> tuple[float, float]:
        """The current (linear [m/s], angular [rad/s]); zero when not pressed."""
        if self._pressed_at is None:
            return (0.0, 0.0)
        return joystick_command(
            self._center[0],
            self._center[1],
            self._pressed_at[0],
            self._pressed_at[1],
            self._radius,
            self.linear_max,
            self.angular_max,
        )

    def set_geometry(self, center_x: float, center_y: float, radius: float) -> None:
        """The widget was resized: new centre and radius [px]."""
        _Geometry(center_x, center_y, radius)
        self._center = (float(center_x), float(center_y))
        self._radius = float(radius)

    def set_limits(self, linear_max: float, angular_max: float) -> tuple[float, float]:
        """New maxima from the sliders; returns the updated command."""
        _Limits(linear_max, angular_max)
        self.linear_max, self.angular_max = float(linear_max), float(angular_max)
        return self.command

    def press(self, x: float, y: float) -> tuple[float, float]:
        _Pressed(x, y)
        self._pressed_at = (float(x), float(y))
        return self.command

    def release(self) -> tuple[float, float]:
        self._pressed_at = None
        return (0.0, 0.0)
