"""Kiosk mode: the only way out of the full-screen tablet is an operator's gesture.

Anyone in the building uses the tablet, so closing it must not be one tap away. In kiosk mode
the window ignores close requests (a window manager's close button, Alt+F4) until the operator
taps the top-left corner of the header `TAPS` times within `WINDOW_S` seconds and confirms.
`ExitGesture` is that rule, with time passed in.
"""

from __future__ import annotations

from collections import deque

TAPS = 5
WINDOW_S = 3.0  # [s]
CORNER_PX = 80  # [px] the corner of the header that counts


class ExitGesture:
    """``tap(now)`` is True on the tap that completes `TAPS` taps within `WINDOW_S` seconds."""

    def __init__(self, taps: int = TAPS, window_s: float = WINDOW_S) -> None:
        if taps < 2 or window_s <= 0:
            raise ValueError(f"need taps >= 2 and window_s > 0, got {taps}, {window_s}")
        self._taps = taps
        self._window = window_s
        self._times: deque[float] = deque(maxlen=taps)

    def tap(self, now: float) -> bool:
        self._times.append(now)
        done = len(self._times) == self._taps and now - self._times[0] <= self._window
        if done:
            self._times.clear()
        return done
