"""A token bucket: at most ``rate`` messages a second on average, ``burst`` at once.

The classic shaper (Turner 1986; Linux ``tc tbf``): the bucket holds up to ``burst`` tokens,
refills at ``rate`` tokens per second, and each message takes one; a message that finds the
bucket empty is refused. Pure: time is passed in.
"""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from interbot_core import schema

Rate = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "messages/s"})]


class TokenBucket:
    """``allow(now)`` is True while the sender keeps to ``rate`` [1/s] with bursts of ``burst``."""

    def __init__(self, rate: float, burst: int) -> None:
        self.rate: float = schema.checked(rate, Rate, "TokenBucket.rate")
        self.burst: int = schema.checked(burst, Annotated[int, Meta(ge=1)], "TokenBucket.burst")
        self._tokens = float(burst)
        self._last: float | None = None
        self.refused = 0

    def reset(self) -> None:
        self._tokens = float(self.burst)
        self._last = None
        self.refused = 0

    def allow(self, now: float) -> bool:
        """Take one token at ``now`` [s]; False (counted in ``refused``) when there is none."""
        if self._last is not None and now > self._last:
            self._tokens = min(float(self.burst), self._tokens + (now - self._last) * self.rate)
        if self._last is None or now > self._last:
            self._last = now
        if self._tokens >= 1.0:
            self._tokens -= 1.0
            return True
        self.refused += 1
        return False
