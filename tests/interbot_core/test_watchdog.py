"""Tests for interbot_core.watchdog (thesis §5.3.4, Table 6.8)."""

from __future__ import annotations

import math

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

from interbot_core.watchdog import LatencyWatchdog, PeriodStats


def test_expired_before_first_command() -> None:
    dog = LatencyWatchdog(0.2)
    assert dog.expired(0.0)
    assert dog.latency(0.0) == math.inf
    assert dog.last_feed is None


def test_expires_strictly_after_ceiling_and_feed_restarts() -> None:
    dog = LatencyWatchdog(0.25)
    assert dog.feed(1.0) is None
    assert not dog.expired(1.25)  # exactly the ceiling: not exceeded
    assert dog.expired(1.2501)
    assert dog.latency(1.5) == pytest.approx(0.5)
    assert dog.feed(1.5) == pytest.approx(0.5)
    assert not dog.expired(1.6)
    dog.reset()
    assert dog.expired(1.6)


def test_ceiling_changes_at_run_time_and_is_validated() -> None:
    dog = LatencyWatchdog(0.5)
    dog.feed(0.0)
    assert not dog.expired(0.3)
    dog.ceiling_s = 0.2
    assert dog.ceiling_s == 0.2
    assert dog.expired(0.3)
    out_of_range = r"watchdog\.ceiling_s = -?[01]\.0 s is outside the allowed range \(0, inf\) s"
    not_finite = r"watchdog\.ceiling_s must be a finite number \[s\], got (nan|inf)"
    for bad, message in ((0.0, out_of_range), (-1.0, out_of_range), (math.nan, not_finite)):
        with pytest.raises(ValueError, match=message):
            dog.ceiling_s = bad
        with pytest.raises(ValueError, match=message):
            LatencyWatchdog(bad)
    with pytest.raises(ValueError, match=not_finite):
        LatencyWatchdog(math.inf)
    with pytest.raises(ValueError, match=r"watchdog\.ceiling_s must be a number \[s\], got '1'"):
        LatencyWatchdog("1")  # type: ignore[arg-type]
    assert dog.ceiling_s == 0.2
    with pytest.raises(ValueError, match=r"watchdog\.now must be a finite number \[s\]"):
        dog.feed(math.nan)


@settings(max_examples=100, deadline=None)
@given(
    ceiling=st.floats(0.01, 5.0),
    gaps=st.lists(st.floats(0.0, 10.0), min_size=1, max_size=20),
    probe=st.floats(0.0, 10.0),
)
def test_expired_iff_gap_exceeds_ceiling(ceiling: float, gaps: list[float], probe: float) -> None:
    dog = LatencyWatchdog(ceiling)
    now = 0.0
    for gap in gaps:
        now += gap
        dog.feed(now)
    probe_time = now + probe
    assert dog.expired(probe_time) == (probe_time - now > ceiling)  # same float arithmetic


def test_period_stats_matches_numpy_and_counts_above_threshold() -> None:
    stats = PeriodStats(capacity=100)
    periods = [0.1, 0.1, 0.12, 0.09, 0.35, 0.1]
    for p in periods:
        stats.add_period(p)
    assert stats.count == 6
    assert stats.mean() == pytest.approx(np.mean(periods))
    assert stats.std() == pytest.approx(np.std(periods))
    assert stats.std(ddof=1) == pytest.approx(np.std(periods, ddof=1))
    assert stats.percentile(50) == pytest.approx(np.percentile(periods, 50))
    assert stats.count_above(0.2) == 1
    summary = stats.summary(threshold=0.11)
    assert (summary.count, summary.above_threshold, summary.maximum) == (6, 2, 0.35)
    assert summary.p99 == pytest.approx(np.percentile(periods, 99))
    values, edges = stats.histogram(bins=5)
    assert values.sum() == pytest.approx(1.0)
    assert edges[0] == 0.09 and edges[-1] == 0.35


def test_period_stats_from_arrivals() -> None:
    stats = PeriodStats()
    assert stats.add_arrival(0.0) is None
    assert stats.add_arrival(0.1) == pytest.approx(0.1)
    assert stats.add_arrival(0.3) == pytest.approx(0.2)
    assert stats.count == 2
    assert stats.mean() == pytest.approx(0.15)


def test_period_stats_ring_buffer_keeps_last_n() -> None:
    stats = PeriodStats(capacity=3)
    for p in (1.0, 2.0, 3.0, 4.0, 5.0):
        stats.add_period(p)
    assert stats.count == 3
    assert stats.total_count == 5
    assert stats.values().tolist() == [3.0, 4.0, 5.0]
    assert stats.mean() == pytest.approx(4.0)
    stats.clear()
    assert stats.count == 0 and stats.total_count == 0


def test_period_stats_empty_and_invalid() -> None:
    stats = PeriodStats(capacity=4)
    assert math.isnan(stats.mean()) and math.isnan(stats.std()) and math.isnan(stats.percentile(5))
    assert stats.summary(0.2).count == 0
    assert stats.count_above(0.0) == 0
    with pytest.raises(
        ValueError, match=r"period = -0\.1 s is outside the allowed range \[0, inf\) s"
    ):
        stats.add_period(-0.1)
    with pytest.raises(
        ValueError, match=r"percentile = 101 is outside the allowed range \[0, 100\]"
    ):
        stats.percentile(101)
    with pytest.raises(
        ValueError, match=r"PeriodStats\.capacity = 0 is outside the allowed range 1\.\."
    ):
        PeriodStats(capacity=0)


@settings(max_examples=100, deadline=None)
@given(
    capacity=st.integers(1, 20),
    periods=st.lists(st.floats(0.0, 2.0), max_size=60),
)
def test_window_is_the_last_capacity_periods(capacity: int, periods: list[float]) -> None:
    stats = PeriodStats(capacity)
    for p in periods:
        stats.add_period(p)
    window = periods[-capacity:] if periods else []
    assert stats.values().tolist() == window
    if window:
        assert stats.mean() == pytest.approx(float(np.mean(window)))
        assert stats.count_above(1.0) == sum(p > 1.0 for p in window)
