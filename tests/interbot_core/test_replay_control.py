"""Replay control: the clock's semantics and the validated codecs."""

from __future__ import annotations

import math

import pytest

from interbot_core.replay_control import (
    ReplayClock,
    ReplayCommand,
    ReplayError,
    ReplayState,
    ReplayWatch,
    control_key,
    decode_command,
    decode_state,
    encode,
    robot_of_state_key,
    state_key,
)
from interbot_core.topics import TopicDecodeError


def test_clock_plays_pauses_changes_speed_and_seeks() -> None:
    clock = ReplayClock(100.0, now=10.0)
    assert clock.position(12.0) == pytest.approx(2.0)
    clock.apply(ReplayCommand("speed", 20.0), 12.0)
    assert clock.position(13.0) == pytest.approx(22.0)
    clock.apply(ReplayCommand("pause"), 13.0)
    assert clock.position(50.0) == pytest.approx(22.0)
    clock.apply(ReplayCommand("seek", 80.0), 50.0)
    assert clock.position(60.0) == pytest.approx(80.0)  # still paused
    clock.apply(ReplayCommand("play"), 60.0)
    assert clock.position(60.5) == pytest.approx(90.0)
    assert clock.position(70.0) == 100.0  # stops at the end
    assert not clock.state(70.0).playing
    clock.apply(ReplayCommand("play"), 70.0)  # play at the end starts over
    assert clock.position(70.1) == pytest.approx(2.0)
    clock.apply(ReplayCommand("seek", 1e6), 71.0)
    assert clock.position(71.0) == 100.0
    clock.apply(ReplayCommand("speed", 0.5), 71.0)
    assert clock.speed == 0.5


def test_codecs_round_trip_and_refuse_bad_values() -> None:
    for message in (ReplayCommand("seek", 12.5), ReplayCommand("pause")):
        assert decode_command(encode(message)) == message
    state = ReplayState(True, 20.0, 3.0, 10.0, "a.mcap")
    assert decode_state(encode(state)) == state
    for bad in (
        b'{"action":"rewind"}',
        b'{"action":"speed","value":25}',
        b'{"action":"speed","value":0.1}',
        b'{"action":"seek","value":-1}',
        b'{"action":"seek","value":NaN}',
        b'{"action":"play","extra":1}',
        b"[]",
        b"\xff",
        b"x" * 2000,
    ):
        with pytest.raises(TopicDecodeError):
            decode_command(bad)
    with pytest.raises(TopicDecodeError):
        decode_state(b'{"playing":true,"speed":1,"position":11,"duration":10}')
    with pytest.raises(ReplayError):
        ReplayCommand("speed", math.inf)


def test_keys() -> None:
    assert control_key("r1") == "interbot-replay/r1/control"
    assert robot_of_state_key(state_key("r1")) == "r1"
    with pytest.raises(ReplayError):
        robot_of_state_key("interbot/r1/state")


def test_watch_forgets_a_replay_that_went_quiet() -> None:
    watch = ReplayWatch(freshness=2.0)
    state = ReplayState(True, 1.0, 0.0, 5.0)
    watch.update({"r1": state}, now=10.0)
    assert watch.state("r1", 11.9) == state
    assert watch.state("r1", 12.1) is None
    assert watch.state("r2", 10.0) is None and watch.state(None, 10.0) is None
