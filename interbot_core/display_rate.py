"""When the station redraws: the newest robot state, at the display rate, never per message.

Issue 14 (commands off the drawing path): the station's Qt thread both forwards the tablet's
commands and draws. Every millisecond it spends drawing is a millisecond a command arriving
then waits. The robot publishes its laser at 40 Hz and its pose at up to 100 Hz, far more than
an operator can see, so the station pulls the newest state often (cheap: rings of one, see
`interbot_link.StationLink`) but draws at most ``max_hz`` frames a second; the messages that
arrived between two frames are coalesced (only the newest of each is drawn).

`DisplayRate` is that decision, with the time injected: ``due(now)`` is True at most once per
``1 / max_hz`` seconds, and it counts the polls it held back (``coalesced``).
"""

from __future__ import annotations

import math
from typing import Annotated

from msgspec import Meta

from interbot_core import schema

#: [Hz] the station's default drawing rate (issue 14: 10-20 Hz, coalesced).
DEFAULT_DISPLAY_HZ = 15.0
MIN_DISPLAY_HZ = 1.0
MAX_DISPLAY_HZ = 60.0
_EPS_S = 1e-9  # [s] sums of periods in floating point land a hair early
DisplayHz = Annotated[float, Meta(ge=MIN_DISPLAY_HZ, le=MAX_DISPLAY_HZ, extra={"unit": "Hz"})]


class DisplayRate:
    """At most ``max_hz`` frames a second; polls in between are coalesced into the next frame."""

    def __init__(self, max_hz: float = DEFAULT_DISPLAY_HZ) -> None:
        self.period_s = 1.0 / schema.checked(max_hz, DisplayHz, "display rate")
        self._last: float | None = None
        self.frames = 0
        """Frames allowed so far."""
        self.coalesced = 0
        """Polls held back (their state is drawn with the next frame)."""

    def due(self, now: float) -> bool:
        """True (and the frame is counted) when a frame may be drawn at ``now`` [s].

        A clock that goes backwards (a replaced clock) draws at once rather than freezing.
        """
        last = self._last
        since = math.inf if last is None else now - last
        if 0.0 <= since < self.period_s - _EPS_S:
            self.coalesced += 1
            return False
        # Keep the cadence (no drift from timer jitter) unless we fell behind a whole period.
        if last is not None and 0.0 <= since < 2.0 * self.period_s:
            self._last = last + self.period_s
        else:
            self._last = now
        self.frames += 1
        return True

    def reset(self) -> None:
        """The next poll draws (e.g. another robot was selected)."""
        self._last = None
