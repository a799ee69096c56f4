"""The Wi-Fi link model: in order, lossless, slower inside lossy zones, seeded."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robot_daemon.sim.wifi import LossyZone, WifiConfig, WifiConfigError, WifiLink

ZONE = LossyZone(10.0, 0.0, 3.0, p_good_to_bad=0.2)

IDEAL = WifiConfig(0.001, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)  # a wired-like link: 1 ms, never bad


def _stream(seed: int, n: int, x_of: object = lambda k: 0.0) -> list:
    link = WifiLink(WifiConfig(zones=(ZONE,)), np.random.default_rng(seed))
    out = []
    for k in range(n):
        link.send(0.1 * k, k, (x_of(k), 0.0))  # type: ignore[operator]
        out += link.receive(0.1 * k)
    out += link.receive(1e9)
    return out


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 400))
def test_in_order_and_never_lost(seed: int, n: int) -> None:
    got = _stream(seed, n, lambda k: 8.0 + 0.02 * k)
    assert [d.payload for d in got] == list(range(n))
    received = [d.received for d in got]
    assert received == sorted(received)
    assert all(d.received >= d.sent for d in got)


def test_deterministic_for_a_seed() -> None:
    a = [d.received for d in _stream(5, 300, lambda k: 9.0)]
    b = [d.received for d in _stream(5, 300, lambda k: 9.0)]
    c = [d.received for d in _stream(6, 300, lambda k: 9.0)]
    assert a == b
    assert a != c


def test_delays_more_inside_the_zone() -> None:
    outside = [d.received - d.sent for d in _stream(1, 2000, lambda k: 0.0)]
    inside = [d.received - d.sent for d in _stream(1, 2000, lambda k: 10.0)]
    assert np.mean(inside) > 3 * np.mean(outside)
    assert max(inside) > 0.2
    assert np.median(outside) < 0.02


def test_bad_state_delays_in_range_and_head_of_line_blocking() -> None:
    cfg = WifiConfig(p_good_to_bad=1.0, p_bad_to_good=1.0, jitter=0.0, base_delay=0.0)
    link = WifiLink(cfg, np.random.default_rng(0))
    first = link.send(0.0, "a")  # good -> bad: retransmitted
    second = link.send(0.1, "b")  # bad -> good: fast, but waits behind the first
    assert first.bad and 0.2 <= first.received - first.sent <= 1.5
    assert not second.bad
    assert second.received == first.received
    assert [d.payload for d in link.receive(first.received)] == ["a", "b"]


def test_handover_stall_when_crossing_a_zone_boundary() -> None:
    zone = LossyZone(0.0, 0.0, 1.0, p_good_to_bad=0.0)
    cfg = WifiConfig(p_good_to_bad=0.0, jitter=0.0, zones=(zone,))
    link = WifiLink(cfg, np.random.default_rng(0))
    link.send(0.0, 1, (5.0, 0.0))
    crossing = link.send(0.1, 2, (0.5, 0.0))
    assert link.handovers == 1
    assert 0.3 <= crossing.received - crossing.sent <= 1.2 + cfg.base_delay
    assert link.send(0.2, 3, (0.4, 0.0)).received == crossing.received  # still stalled


def test_messages_are_not_delivered_early() -> None:
    link = WifiLink(IDEAL, np.random.default_rng(0))
    link.send(1.0, "x")
    assert link.receive(1.0005) == []
    assert [d.payload for d in link.receive(1.001)] == ["x"]


@pytest.mark.parametrize(
    "kwargs", [{"base_delay": -1.0}, {"p_bad_to_good": 0.0}, {"bad_delay_max": 0.1}]
)
def test_invalid_config_names_the_field(kwargs: dict[str, float]) -> None:
    with pytest.raises(WifiConfigError, match=next(iter(kwargs))):
        WifiConfig(**kwargs)


def test_send_times_must_not_go_back() -> None:
    link = WifiLink(IDEAL, np.random.default_rng(0))
    link.send(1.0, "x")
    with pytest.raises(ValueError, match="non-decreasing"):
        link.send(0.5, "y")
