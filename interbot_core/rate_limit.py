"""A token bucket: at most ``rate`` messages a second on average, ``burst`` at once.

The classic shaper (Turner 1986; Linux ``tc tbf``): the bucket holds up to ``burst`` tokens,
refills at ``rate`` tokens per second, and each message takes one; a message that finds the
bucket empty is refused. Pure: time is passed in.
"""

from __future__ import annotations

import math


class TokenBucket:
    """``allow(now)`` is True while the sender keeps to ``rate`` [1/s] with bursts of ``burst``."""

    def __init__(self, rate: float, burst: int) -> None:
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"rate must be finite and > 0 messages/s, got {rate!r}")
        if burst < 1:
            raise ValueError(f"burst must be >= 1 message, got {burst!r}")
        self.rate = float(rate)
        self.burst = int(burst)
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
