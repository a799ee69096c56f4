"""Link health of the Tablet <-> Base Station connection (thesis §4.2.1.1, §5.2.2.3, §5.3.4).

The thesis shows "the connection status to the Base Station ... as well as the average latency"
and warns the joystick user "in the event of a lossy connection ... that the speed commands will
not be processed by the Base Station", because its watchdog (§5.3.4) drops speed commands when
the latency exceeds a ceiling. These are the pure parts of that, tested without Qt or a clock:

* `ReconnectBackoff`: reconnect delays doubling from 0.5 s up to 5 s, reset on success.
* `LatencyMonitor`: pings sent, pongs received, the mean round trip of the last pongs, and the
  "lossy" decision: a ping unanswered for longer than ``pong_timeout`` or a mean round trip over
  the ``ceiling``.

Time is passed in (``now``, monotonic seconds).
"""

from __future__ import annotations

import logging
from collections import OrderedDict, deque
from typing import Annotated, ClassVar

from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)


Delay = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "s"})]


class BackoffConfig(schema.Declared, frozen=True):
    """Reconnect delays [s]: ``initial``, multiplied by ``factor`` after each failure, capped."""

    ROOT: ClassVar[str] = "backoff"
    ERROR: ClassVar[type[Exception]] = ValueError
    initial: Delay = 0.5
    maximum: Delay = 5.0
    factor: Annotated[float, Meta(ge=1.0, le=schema.FINITE)] = 2.0

    def check(self) -> None:
        if self.maximum < self.initial:
            raise ValueError(
                f"backoff.maximum ({self.maximum} s) must be >= initial ({self.initial} s)"
            )


class ReconnectBackoff:
    """Exponential back-off: 0.5, 1, 2, 4, 5, 5, ... s by default; `reset` after a success."""

    def __init__(self, config: BackoffConfig | None = None) -> None:
        self.config = config or BackoffConfig()
        self._next = self.config.initial

    def next_delay(self) -> float:
        """The delay before the next attempt [s]; each call lengthens the following one."""
        delay = self._next
        self._next = min(self.config.maximum, self._next * self.config.factor)
        return delay

    def reset(self) -> None:
        self._next = self.config.initial


class LatencyConfig(schema.Declared, frozen=True):
    """``window`` pongs averaged; ``pong_timeout`` [s] and ``ceiling`` [s] decide "lossy"."""

    ROOT: ClassVar[str] = "latency"
    ERROR: ClassVar[type[Exception]] = ValueError
    window: Annotated[int, Meta(ge=1, le=10_000)] = 10
    pong_timeout: Delay = 1.0
    ceiling: Delay = 0.5


class LatencyMonitor:
    """Round trips of pings, their running mean, and whether the link is lossy."""

    def __init__(self, config: LatencyConfig | None = None) -> None:
        self.config = config or LatencyConfig()
        self._outstanding: OrderedDict[int, float] = OrderedDict()  # seq -> sent at [s]
        self._round_trips: deque[float] = deque(maxlen=self.config.window)

    def reset(self) -> None:
        """Forget everything (a new connection)."""
        self._outstanding.clear()
        self._round_trips.clear()

    def ping_sent(self, seq: int, now: float) -> None:
        self._outstanding[seq] = now
        # Bound memory on a dead link: older unanswered pings only matter through the oldest.
        while len(self._outstanding) > 1000:
            self._outstanding.popitem(last=False)
            logger.debug("dropping the record of an unanswered ping")

    def pong_received(self, seq: int, now: float) -> float | None:
        """Record the pong of ping ``seq``; returns its round trip [s], None if unknown."""
        sent = self._outstanding.get(seq)
        if sent is None:
            return None
        for old in [s for s in self._outstanding if s <= seq]:
            del self._outstanding[old]  # earlier pings are overtaken (TCP keeps order)
        round_trip = max(0.0, now - sent)
        self._round_trips.append(round_trip)
        return round_trip

    @property
    def average(self) -> float | None:
        """Mean round trip of the last ``window`` pongs [s]; None before the first."""
        if not self._round_trips:
            return None
        return sum(self._round_trips) / len(self._round_trips)

    def oldest_unanswered_age(self, now: float) -> float:
        """How long the oldest outstanding ping has waited [s]; 0 when none is outstanding."""
        if not self._outstanding:
            return 0.0
        return max(0.0, now - next(iter(self._outstanding.values())))

    def is_lossy(self, now: float) -> bool:
        """True when a ping waits longer than ``pong_timeout`` or the mean exceeds ``ceiling``."""
        if self.oldest_unanswered_age(now) > self.config.pong_timeout:
            return True
        average = self.average
        return average is not None and average > self.config.ceiling
