"""Pure safety pieces (issue 11): speed freshness, the token bucket, the route mirror."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from interbot_core.rate_limit import TokenBucket
from interbot_core.route_mirror import RouteMirror
from interbot_core.speed_freshness import MAX_CEILING_S, SpeedFreshness
from interbot_core.topics import RouteProgress


# ------------------------------------------------------------------ SpeedFreshness
def test_thesis_era_commands_without_stamps_pass() -> None:
    f = SpeedFreshness(0.5)
    assert all(f.check(None, None, now).fresh for now in (0.0, 0.1, 5.0))


def test_out_of_order_and_repeated_seq_are_dropped() -> None:
    f = SpeedFreshness(0.5)
    assert f.check(5, None, 0.0).fresh
    assert not f.check(5, None, 0.1).fresh
    assert not f.check(4, None, 0.2).fresh
    assert f.check(6, None, 0.3).fresh
    assert f.dropped_out_of_order == 2


def test_backlog_after_a_stall_is_stale_whatever_the_clock_offset() -> None:
    f = SpeedFreshness(0.5)
    offset = 1234.5  # the tablet's clock is far from the station's: only differences count
    for k in range(10):  # 10 Hz, 5 ms delivery
        assert f.check(k, k * 0.1, offset + k * 0.1 + 0.005).fresh
    # The app froze for 3 s; the ten commands it had queued arrive at once.
    verdicts = [f.check(10 + k, 1.0 + k * 0.1, offset + 4.0).fresh for k in range(10)]
    assert verdicts == [False] * 10
    assert f.dropped_stale == 10
    assert f.check(20, 4.0, offset + 4.005).fresh  # the first fresh one drives again


def test_ceiling_is_at_most_one_second() -> None:
    with pytest.raises(ValueError, match="ceiling"):
        SpeedFreshness(MAX_CEILING_S + 0.01)
    f = SpeedFreshness(0.2)
    with pytest.raises(ValueError):
        f.ceiling_s = 10.0
    assert f.ceiling_s == 0.2


@given(st.lists(st.floats(0.0, 0.4), min_size=1, max_size=50), st.floats(-1e6, 1e6))
def test_commands_within_the_ceiling_of_the_fastest_always_pass(
    delays: list[float], offset: float
) -> None:
    f = SpeedFreshness(0.5)
    for k, delay in enumerate(delays):
        assert f.check(k, k * 0.1, offset + k * 0.1 + delay).fresh


# ------------------------------------------------------------------ TokenBucket
def test_token_bucket_allows_bursts_then_the_rate() -> None:
    bucket = TokenBucket(rate=10.0, burst=5)
    assert [bucket.allow(0.0) for _ in range(7)] == [True] * 5 + [False] * 2
    assert bucket.allow(0.1) and not bucket.allow(0.1)  # one token per 0.1 s
    allowed = sum(bucket.allow(1.0 + k * 0.001) for k in range(1000))  # 1000 msg in 1 s
    assert allowed <= 5 + 11
    assert bucket.refused > 980


def test_token_bucket_refuses_bad_settings() -> None:
    with pytest.raises(ValueError):
        TokenBucket(0.0, 1)
    with pytest.raises(ValueError):
        TokenBucket(1.0, 0)


# ------------------------------------------------------------------ RouteMirror
def _p(route_id: int, state: str) -> RouteProgress:
    return RouteProgress(route_id, 0, state == "succeeded", state)


def test_mirror_keeps_a_route_the_robot_still_drives() -> None:
    m = RouteMirror()
    m.started(42)
    m.reconnected(10.0)
    assert m.checking
    assert m.on_progress(_p(42, "active")) is None
    assert not m.checking and m.route_id == 42


def test_mirror_ignores_a_stale_report_of_an_older_route_in_normal_operation() -> None:
    m = RouteMirror()
    m.started(42)
    assert m.on_progress(_p(7, "succeeded")) is None
    assert m.route_id == 42


@pytest.mark.parametrize(
    ("report", "why"),
    [(_p(0, "idle"), "has no route"), (_p(9, "active"), "now has route 9")],
)
def test_mirror_loses_the_route_after_a_restart(report: RouteProgress, why: str) -> None:
    m = RouteMirror()
    m.started(42)
    m.reconnected(10.0)
    lost = m.on_progress(report)
    assert lost is not None and lost.route_id == 42 and why in lost.reason
    assert m.route_id is None


def test_mirror_loses_the_route_when_the_robot_stays_silent() -> None:
    m = RouteMirror(answer_timeout=5.0)
    m.started(42)
    m.reconnected(10.0)
    assert m.check_timeout(15.0) is None
    lost = m.check_timeout(15.1)
    assert lost is not None and "did not report" in lost.reason
    assert m.check_timeout(20.0) is None


def test_mirror_sees_a_route_it_did_not_start() -> None:
    m = RouteMirror()
    assert m.on_progress(_p(77, "active")) is None
    assert m.foreign is not None and m.foreign.route_id == 77 and m.robot_running
    m.on_progress(_p(77, "canceled"))
    assert m.foreign is None and not m.robot_running


# ------------------------------------------------------------------ TabletInputPolicy
def test_input_policy_caps_a_turn_and_the_rate_but_admits_the_stop() -> None:
    from interbot_core.tablet_input_policy import InputPolicyConfig, TabletInputPolicy

    policy = TabletInputPolicy(InputPolicyConfig(rate=10.0, burst=5, max_per_turn=3))
    admitted = [policy.admit({"speed": {}}, 0.0) for _ in range(6)]
    assert admitted == [True, True, True, False, False, False]
    assert policy.admit({"stop": True}, 0.0)  # past the cap: the stop still passes
    assert not policy.admit({"stop": True}, 0.0)  # once per turn
    error = policy.end_turn(0.0)
    assert error is not None and "4 message(s) dropped" in error
    assert policy.admit({"speed": {}}, 0.01) and policy.admit({"speed": {}}, 0.01)
    assert not policy.admit({"speed": {}}, 0.01)  # the bucket (5) is empty
    assert policy.end_turn(0.5) is None  # one error a second at most
    assert policy.end_turn(1.1) is not None
