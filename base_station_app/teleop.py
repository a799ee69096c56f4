"""Base Station teleoperation input: arrow pad, keyboard and mouse joystick (thesis §4.2.2.1, §5.3).

The operator drives the robot with the arrow keypad, keyboard shortcuts (arrows / WASD) or the
virtual joystick, at adjustable maximum speeds. `TeleopInput` merges them into one command:
while the joystick is held it wins; otherwise each held direction contributes its full speed,
``linear = (forward - backward) * linear_max`` and ``angular = (left - right) * angular_max``
(REP-103: positive angular turns left). Releasing everything gives zero, and `release_all`
is what the window calls when it loses focus, so a key released in another window can never
leave the robot driving. The Qt side maps keys and buttons to `Direction` values.
"""

from __future__ import annotations

import enum
import logging
from typing import Annotated

from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)

Limit = Annotated[float, Meta(gt=0.0, le=schema.FINITE)]  # a speed limit, > 0


class Direction(enum.Enum):
    FORWARD = "forward"
    BACKWARD = "backward"
    LEFT = "left"
    RIGHT = "right"


class TeleopInput:
    """Held directions and the joystick, turned into (linear [m/s], angular [rad/s])."""

    def __init__(self, linear_max: float = 0.4, angular_max: float = 0.8) -> None:
        self._held: set[Direction] = set()
        self._joystick: tuple[float, float] | None = None
        self.set_limits(linear_max, angular_max)

    def set_limits(self, linear_max: float, angular_max: float) -> None:
        self.linear_max = schema.checked(linear_max, Limit, "teleop linear_max")
        self.angular_max = schema.checked(angular_max, Limit, "teleop angular_max")

    @property
    def active(self) -> bool:
        """True while any key or pad button is held or the joystick is pressed."""
        return bool(self._held) or self._joystick is not None

    @property
    def held(self) -> frozenset[Direction]:
        return frozenset(self._held)

    def press(self, direction: Direction) -> None:
        self._held.add(direction)

    def release(self, direction: Direction) -> None:
        self._held.discard(direction)

    def set_joystick(self, linear: float, angular: float, pressed: bool) -> None:
        """The joystick's command [m/s], [rad/s]; ``pressed=False`` when it is let go."""
        self._joystick = (float(linear), float(angular)) if pressed else None

    def release_all(self) -> None:
        """Forget every held key, button and the joystick (focus lost, e-stop)."""
        self._held.clear()
        self._joystick = None

    def command(self) -> tuple[float, float]:
        """The merged command, clamped to the limits; (0, 0) when nothing is held."""
        if self._joystick is not None:
            linear, angular = self._joystick
        else:
            held = self._held
            linear = ((Direction.FORWARD in held) - (Direction.BACKWARD in held)) * self.linear_max
            angular = ((Direction.LEFT in held) - (Direction.RIGHT in held)) * self.angular_max
        linear = max(-self.linear_max, min(self.linear_max, linear))
        angular = max(-self.angular_max, min(self.angular_max, angular))
        return float(linear), float(angular)
