"""Freshness of the Tablet's speed commands: out-of-order and stale commands never drive.

Thesis §5.3.4 discards the Tablet's speed commands when the link's latency exceeds a ceiling.
A command that sat in a buffer (a frozen app, a stalled Wi-Fi link) and arrives late is just as
stale, even though it has only now *arrived*. When the Tablet stamps its commands
(``speed.seq``, a counter, and ``speed.t``, its own monotonic clock in seconds) the station can
tell:

* **order** - a command whose ``seq`` is not greater than the last accepted one is dropped;
* **age** - the two clocks are not synchronised, so the age of a command is measured against
  the fastest delivery seen so far (the minimum-delay filter of NTP, RFC 5905 §10)::

      offset_i = arrival_i - t_i          (station clock minus tablet clock, plus the delay)
      age_i    = offset_i - min_j offset_j  (how much longer than the fastest command it took)

  and a command with ``age > ceiling`` is dropped. The minimum is taken over the last
  ``window`` commands so a slow drift of either clock cannot hold it for ever.

A thesis-era tablet sends neither field: its commands pass (only the newest of a burst is
forwarded, by the server, and the station's watchdog stops a silent one). Pure: the arrival time
is passed in.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Annotated

from msgspec import Meta

from interbot_core import schema

MAX_CEILING_S = 1.0
Ceiling = Annotated[float, Meta(gt=0.0, le=MAX_CEILING_S, extra={"unit": "s"})]
"""[s] the largest latency ceiling the station accepts (issue 11: a stale command never drives
for longer than this)."""


@dataclass(frozen=True)
class Verdict:
    """``fresh``: forward it; otherwise ``reason`` says why it was dropped."""

    fresh: bool
    reason: str = ""
    age: float = 0.0  # [s] estimated extra delay of this command (0 without a stamp)


class SpeedFreshness:
    """Accepts or drops speed commands by ``seq`` and ``t`` (see the module docstring)."""

    def __init__(self, ceiling_s: float, window: int = 600) -> None:
        self.ceiling_s = ceiling_s
        if window < 1:
            raise ValueError(f"window must be >= 1 command, got {window!r}")
        self._offsets: deque[float] = deque(maxlen=window)
        self._last_seq: int | None = None
        self.dropped_out_of_order = 0
        self.dropped_stale = 0

    @property
    def ceiling_s(self) -> float:
        return self._ceiling

    @ceiling_s.setter
    def ceiling_s(self, value: float) -> None:
        self._ceiling: float = schema.checked(value, Ceiling, "SpeedFreshness.ceiling_s")

    def reset(self) -> None:
        """A new connection: forget the order and the clock offset."""
        self._offsets.clear()
        self._last_seq = None

    def check(self, seq: int | None, t: float | None, arrival: float) -> Verdict:
        """Judge one command that arrived at ``arrival`` [s, station clock]."""
        if seq is not None and self._last_seq is not None and seq <= self._last_seq:
            self.dropped_out_of_order += 1
            return Verdict(False, f"out of order (seq {seq} after {self._last_seq})")
        age = 0.0
        if t is not None:
            offset = arrival - t
            self._offsets.append(offset)
            age = offset - min(self._offsets)
            if age > self._ceiling:
                if seq is not None:
                    self._last_seq = seq
                self.dropped_stale += 1
                return Verdict(
                    False, f"stale ({age * 1000:.0f} ms late > ceiling {self._ceiling:g} s)", age
                )
        if seq is not None:
            self._last_seq = seq
        return Verdict(True, "", age)
