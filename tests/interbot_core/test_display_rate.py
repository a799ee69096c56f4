"""`DisplayRate`: the station draws the newest state at most ``max_hz`` times a second."""

from __future__ import annotations

import math

import pytest

from interbot_core.display_rate import DEFAULT_DISPLAY_HZ, DisplayRate


def test_polls_between_frames_are_coalesced() -> None:
    rate = DisplayRate(10.0)
    polls = [i * 0.025 for i in range(41)]  # a 40 Hz poll for one second
    drawn = [t for t in polls if rate.due(t)]
    assert drawn == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0])
    assert rate.frames == 11
    assert rate.coalesced == 30


def test_the_cadence_does_not_drift_with_timer_jitter() -> None:
    rate = DisplayRate(10.0)
    assert rate.due(0.0)
    # Polls that come a little late each time still give one frame per 100 ms on average.
    frames = sum(rate.due(0.027 * i) for i in range(1, 371))  # ~10 s
    assert frames == pytest.approx(99, abs=1)


def test_after_a_stall_it_draws_at_once_and_does_not_catch_up() -> None:
    rate = DisplayRate(10.0)
    assert rate.due(0.0)
    assert rate.due(5.0)  # 5 s without polls (a busy machine): one frame, not fifty
    assert not rate.due(5.05)
    assert rate.due(5.1)


def test_a_clock_going_backwards_draws_rather_than_freezing() -> None:
    rate = DisplayRate(10.0)
    assert rate.due(100.0)
    assert rate.due(3.0)
    assert not rate.due(3.01)


def test_reset_draws_the_next_poll() -> None:
    rate = DisplayRate()
    assert rate.period_s == pytest.approx(1.0 / DEFAULT_DISPLAY_HZ)
    assert rate.due(1.0)
    assert not rate.due(1.01)
    rate.reset()
    assert rate.due(1.02)


@pytest.mark.parametrize("bad", [0.0, 0.5, 61.0, math.nan, math.inf, -10.0, True, "15"])
def test_a_rate_outside_the_bounds_is_refused(bad: object) -> None:
    with pytest.raises(ValueError, match="display rate"):
        DisplayRate(bad)  # type: ignore[arg-type]
