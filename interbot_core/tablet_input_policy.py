"""How much of a tablet's input the station handles: bounded work whatever the tablet sends.

Issue 11 (a tablet flooding 71 k messages/s froze the station for 102 s): every received object
passes `TabletInputPolicy.admit` before it is validated or acted on.

* **per turn** - at most ``max_per_turn`` objects are handled in one event-loop turn (one read
  of at most a few KiB, see `interbot_qt.qt_tcp_connection.QtTcpConnection`), the rest of the
  turn is dropped;
* **per second** - a token bucket (`interbot_core.rate_limit.TokenBucket`) of ``rate`` objects
  a second with bursts of ``burst``; the thesis's tablet sends 10 speed commands and one ping a
  second, so the defaults leave it five times the room;
* **the stop always passes** - ``{"stop": ...}`` is admitted once per turn even when the rest is
  dropped: a person pressing stop on a misbehaving tablet is heard;
* the sender learns about drops through one ``error`` per ``error_interval`` (never one per
  dropped message, which would multiply the flood by the answers).

Pure: time is passed in.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from msgspec import Meta

from interbot_core import schema
from interbot_core.rate_limit import TokenBucket

ALWAYS_ADMITTED = "stop"


class InputPolicyConfig(schema.Declared, frozen=True):
    """The policy's limits (declared: an error names the field, the value and the range)."""

    ROOT: ClassVar[str] = "tablet input"
    ERROR: ClassVar[type[Exception]] = ValueError
    rate: Annotated[float, Meta(gt=0.0, le=10_000.0, extra={"unit": "objects/s"})] = 50.0
    burst: Annotated[int, Meta(ge=1, le=10_000)] = 50  # [objects] at once
    max_per_turn: Annotated[int, Meta(ge=1, le=10_000)] = 50  # [objects] per event-loop turn
    # [s] at most one "dropped" error this often
    error_interval: Annotated[float, Meta(gt=0.0, le=60.0, extra={"unit": "s"})] = 1.0


class TabletInputPolicy:
    """Admits or drops each received object (see the module docstring)."""

    def __init__(self, config: InputPolicyConfig | None = None) -> None:
        self.config = config or InputPolicyConfig()
        self._bucket = TokenBucket(self.config.rate, self.config.burst)
        self._in_turn = 0
        self._stop_in_turn = False
        self._dropped_unreported = 0
        self._last_error: float | None = None
        self.dropped = 0  # objects dropped since the connection began

    def reset(self) -> None:
        """A new connection."""
        self._bucket.reset()
        self._in_turn = 0
        self._stop_in_turn = False
        self._dropped_unreported = 0
        self._last_error = None
        self.dropped = 0

    def admit(self, obj: object, now: float) -> bool:
        """True: handle ``obj`` (a decoded JSON object); False: drop it (counted)."""
        self._in_turn += 1
        if isinstance(obj, dict) and ALWAYS_ADMITTED in obj and not self._stop_in_turn:
            self._stop_in_turn = True
            return True
        if self._in_turn <= self.config.max_per_turn and self._bucket.allow(now):
            return True
        self.dropped += 1
        self._dropped_unreported += 1
        return False

    def end_turn(self, now: float) -> str | None:
        """Close the turn; the text of an error to send the tablet about drops, or None."""
        self._in_turn = 0
        self._stop_in_turn = False
        if not self._dropped_unreported:
            return None
        if self._last_error is not None and now - self._last_error < self.config.error_interval:
            return None
        n, self._dropped_unreported = self._dropped_unreported, 0
        self._last_error = now
        c = self.config
        return (
            f"{n} message(s) dropped: at most {c.rate:g} a second (bursts of {c.burst}) and "
            f"{c.max_per_turn} at once are handled"
        )
