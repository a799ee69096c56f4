"""Pure link-health logic: reconnect back-off, latency mean, lossy decision (no Qt, no clock)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tablet_app.link_health import BackoffConfig, LatencyConfig, LatencyMonitor, ReconnectBackoff
from tablet_app.ui_metrics import font_px, touch_target_px


def test_backoff_doubles_from_half_a_second_to_five_and_resets() -> None:
    backoff = ReconnectBackoff()
    assert [backoff.next_delay() for _ in range(7)] == [0.5, 1.0, 2.0, 4.0, 5.0, 5.0, 5.0]
    backoff.reset()
    assert backoff.next_delay() == 0.5


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"initial": 0.0}, r"backoff\.initial = 0\.0 s is outside the allowed range \(0, inf\) s"),
        ({"initial": 2.0, "maximum": 1.0}, r"backoff\.maximum \(1\.0 s\) must be >= initial"),
        ({"factor": 0.5}, r"backoff\.factor = 0\.5 is outside the allowed range \[1, inf\)"),
    ],
)
def test_backoff_config_rejects_nonsense(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        BackoffConfig(**kwargs)
    with pytest.raises(ValueError, match=r"latency\.window = 0 is outside the allowed range 1\.\."):
        LatencyConfig(window=0)


@settings(max_examples=100)
@given(st.integers(min_value=1, max_value=40))
def test_backoff_never_exceeds_the_maximum_and_never_shrinks(n: int) -> None:
    backoff = ReconnectBackoff()
    delays = [backoff.next_delay() for _ in range(n)]
    assert all(0.5 <= d <= 5.0 for d in delays)
    assert delays == sorted(delays)


def test_latency_mean_of_the_last_window_pongs() -> None:
    monitor = LatencyMonitor(LatencyConfig(window=2))
    assert monitor.average is None
    for seq, (sent, received) in enumerate([(0.0, 0.010), (1.0, 1.030), (2.0, 2.050)], 1):
        monitor.ping_sent(seq, sent)
        monitor.pong_received(seq, received)
    assert monitor.average == pytest.approx(0.040)  # (0.030 + 0.050) / 2


def test_unknown_pong_is_ignored() -> None:
    monitor = LatencyMonitor()
    assert monitor.pong_received(99, 1.0) is None
    assert monitor.average is None


def test_lossy_when_a_ping_waits_longer_than_the_timeout() -> None:
    monitor = LatencyMonitor(LatencyConfig(pong_timeout=1.0, ceiling=0.5))
    monitor.ping_sent(1, 10.0)
    assert not monitor.is_lossy(10.9)
    assert monitor.is_lossy(11.01)
    monitor.ping_sent(2, 11.0)
    monitor.pong_received(2, 11.02)  # the newer pong overtakes the lost one
    assert not monitor.is_lossy(11.5)


def test_lossy_when_the_mean_round_trip_exceeds_the_ceiling() -> None:
    monitor = LatencyMonitor(LatencyConfig(pong_timeout=5.0, ceiling=0.2))
    monitor.ping_sent(1, 0.0)
    monitor.pong_received(1, 0.3)
    assert monitor.is_lossy(0.3)
    monitor.reset()
    assert not monitor.is_lossy(100.0)


@pytest.mark.parametrize(
    ("dpi", "size", "expected_min"), [(160, (1280, 800), 57), (96, (640, 480), 44)]
)
def test_touch_targets_are_at_least_9_mm(dpi: float, size: tuple[int, int], expected_min: int):
    px = touch_target_px(dpi, *size)
    assert px >= expected_min
    assert px >= 9.0 / 25.4 * dpi
    assert font_px(px) >= 14


def test_touch_targets_grow_with_the_window() -> None:
    assert touch_target_px(96, 2560, 1600) == 100
    assert touch_target_px(96, 2560, 1600) > touch_target_px(96, 1280, 800)
