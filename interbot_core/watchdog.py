"""Command latency watchdog and inter-arrival period statistics (thesis §5.3.4, Table 6.8, Fig. 6.6).

Thesis §5.3.4: the Base Station restarts a timer on every chunk of speed commands from the Tablet;
the time elapsed since the last chunk is the connection latency, and when it exceeds the ceiling
the Tablet's commands are discarded (the Base Station stops forwarding them). `LatencyWatchdog`
is that timer with time passed in: ``feed(now)`` on every received command, ``expired(now)``
when ``now - last > ceiling`` (or nothing has arrived yet).

`PeriodStats` accumulates the periods between received commands (thesis Table 6.8: mean and
standard deviation of the received command period; Fig. 6.6: their distribution) over a ring
buffer of the last ``capacity`` periods, so memory stays bounded on a long run.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)


Ceiling = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "s"})]
Time = Annotated[float, Meta(ge=-schema.FINITE, le=schema.FINITE, extra={"unit": "s"})]
Period = Annotated[float, Meta(ge=0.0, le=schema.FINITE, extra={"unit": "s"})]
Capacity = Annotated[int, Meta(ge=1, le=100_000_000)]
Percent = Annotated[float, Meta(ge=0.0, le=100.0)]


def _check_ceiling(ceiling_s: float) -> float:
    return float(schema.checked(ceiling_s, Ceiling, "watchdog.ceiling_s"))


def _check_now(now: float) -> float:
    return float(schema.checked(now, Time, "watchdog.now"))


class LatencyWatchdog:
    """Expires when no command has been fed for longer than ``ceiling_s`` [s]."""

    def __init__(self, ceiling_s: float) -> None:
        self._ceiling = _check_ceiling(ceiling_s)
        self._last: float | None = None

    @property
    def ceiling_s(self) -> float:
        """The latency ceiling [s]; may be changed at run time (validated finite > 0)."""
        return self._ceiling

    @ceiling_s.setter
    def ceiling_s(self, value: float) -> None:
        self._ceiling = _check_ceiling(value)
        logger.info("latency watchdog ceiling set to %.3f s", self._ceiling)

    @property
    def last_feed(self) -> float | None:
        """Time of the last command [s], or None before the first."""
        return self._last

    def feed(self, now: float) -> float | None:
        """A command arrived at ``now``; returns the period since the previous one [s] (or None)."""
        now = _check_now(now)
        period = None if self._last is None else now - self._last
        self._last = now
        return period

    def latency(self, now: float) -> float:
        """Time since the last command [s]; ``math.inf`` before the first command."""
        now = _check_now(now)
        return math.inf if self._last is None else now - self._last

    def expired(self, now: float) -> bool:
        """True when ``latency(now) > ceiling_s`` (strict), or no command has arrived yet."""
        return self.latency(now) > self._ceiling

    def reset(self) -> None:
        """Forget the last command (e.g. the Tablet disconnected): expired until the next feed."""
        self._last = None


@dataclass(frozen=True, slots=True)
class PeriodSummary:
    """Statistics of the stored periods [s]; NaN fields when ``count == 0``."""

    count: int
    mean: float
    std: float
    minimum: float
    maximum: float
    p50: float
    p95: float
    p99: float
    above_threshold: int
    threshold: float


class PeriodStats:
    """Inter-arrival periods of received commands over the last ``capacity`` periods.

    ``std`` is the population standard deviation (ddof=0) unless another ``ddof`` is given.
    ``total_count`` counts every period ever added; the statistics cover only the window.
    """

    def __init__(self, capacity: int = 10_000) -> None:
        schema.checked(capacity, Capacity, "PeriodStats.capacity")
        self._buffer = np.zeros(capacity, dtype=np.float64)
        self._next = 0
        self._count = 0
        self._total = 0
        self._last_arrival: float | None = None

    @property
    def capacity(self) -> int:
        return int(self._buffer.size)

    @property
    def count(self) -> int:
        """Periods in the window (at most ``capacity``)."""
        return self._count

    @property
    def total_count(self) -> int:
        """Periods added since construction or the last ``clear()``."""
        return self._total

    def add_period(self, period: float) -> None:
        """Add one period [s] (finite, >= 0); the oldest is dropped when the window is full."""
        period = schema.checked(period, Period, "PeriodStats.period")
        self._buffer[self._next] = period
        self._next = (self._next + 1) % self._buffer.size
        self._count = min(self._count + 1, self._buffer.size)
        self._total += 1

    def add_arrival(self, now: float) -> float | None:
        """Record a message arrival at ``now`` [s]; adds and returns the period since the last."""
        now = _check_now(now)
        previous, self._last_arrival = self._last_arrival, now
        if previous is None:
            return None
        period = now - previous
        self.add_period(period)
        return period

    def clear(self) -> None:
        self._next = self._count = self._total = 0
        self._last_arrival = None

    def values(self) -> npt.NDArray[np.float64]:
        """The stored periods, oldest first (a copy)."""
        if self._count < self._buffer.size:
            return self._buffer[: self._count].copy()
        return np.concatenate((self._buffer[self._next :], self._buffer[: self._next]))

    def _window(self) -> npt.NDArray[np.float64]:
        return self._buffer[: self._count]  # order does not matter for the statistics

    def mean(self) -> float:
        return float(np.mean(self._window())) if self._count else math.nan

    def std(self, ddof: int = 0) -> float:
        if self._count <= ddof:
            return math.nan
        return float(np.std(self._window(), ddof=ddof))

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile (0..100, linear interpolation) [s]; NaN when empty."""
        q = schema.checked(q, Percent, "PeriodStats.percentile")
        return float(np.percentile(self._window(), q)) if self._count else math.nan

    def count_above(self, threshold: float) -> int:
        """Periods strictly longer than ``threshold`` [s] (e.g. the mux timeout, Fig. 6.6a)."""
        return int(np.count_nonzero(self._window() > threshold))

    def histogram(
        self, bins: int = 20, normalise: bool = True
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(values, bin edges) of the window; normalised to sum 1 (thesis Fig. 6.6b) by default."""
        if not self._count:
            return np.zeros(bins), np.linspace(0.0, 1.0, bins + 1)
        counts, edges = np.histogram(self._window(), bins=bins)
        values = counts.astype(np.float64)
        if normalise:
            values /= values.sum()
        return values, edges.astype(np.float64)

    def summary(self, threshold: float) -> PeriodSummary:
        """All statistics at once, periods above ``threshold`` counted."""
        window = self._window()
        if not self._count:
            nan = math.nan
            return PeriodSummary(0, nan, nan, nan, nan, nan, nan, nan, 0, threshold)
        p50, p95, p99 = (float(v) for v in np.percentile(window, [50.0, 95.0, 99.0]))
        return PeriodSummary(
            count=self._count,
            mean=float(window.mean()),
            std=float(window.std()),
            minimum=float(window.min()),
            maximum=float(window.max()),
            p50=p50,
            p95=p95,
            p99=p99,
            above_threshold=self.count_above(threshold),
            threshold=threshold,
        )
