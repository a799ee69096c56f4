"""Look around (issue 16): one slow turn in place per undecided search, never when forbidden.

The policy alone, on a scripted clock and odometry heading: when it turns, how far, and that
an e-stop, a pause or an operator ends the attempt's turn for good.
"""

from __future__ import annotations

import math

import pytest

from interbot_core.geometry import wrap_angle
from robot_daemon.localisation.look_around import (
    LookAround,
    LookAroundConfig,
    LookAroundConfigError,
)

DT = 0.1  # [s] control period


def _run(
    look: LookAround,
    seconds: float,
    since: float | None = 0.0,
    blocker: str | None = None,
    t0: float = 0.0,
    yaw0: float = 0.0,
) -> tuple[list[float | None], float, float]:
    """Step the policy with a robot that turns as commanded; (commands, end time, end yaw)."""
    commands: list[float | None] = []
    yaw, now = yaw0, t0
    for _ in range(round(seconds / DT)):
        w = look.update(since, wrap_angle(yaw), blocker, now)
        commands.append(w)
        yaw += (w or 0.0) * DT
        now = round(now + DT, 9)
    return commands, now, yaw


def test_turns_after_the_delay_and_stops_after_one_full_turn() -> None:
    cfg = LookAroundConfig(angular_speed=0.5, start_after_s=0.5)
    look = LookAround(cfg)
    commands, _, yaw = _run(look, 30.0)
    assert all(w is None for w in commands[:5])  # undecided for less than start_after_s
    assert commands[5] == pytest.approx(0.5) and look.turns_started == 1
    turning = [w for w in commands if w is not None]
    assert all(w == pytest.approx(0.5) for w in turning)  # only rotation, at the set speed
    assert yaw == pytest.approx(2.0 * math.pi, abs=0.1)  # one full turn, not more
    assert look.end_reason == "one full turn done" and not look.turning
    assert commands[-1] is None


def test_no_search_no_turn_and_a_new_attempt_turns_again() -> None:
    look = LookAround()
    commands, _, _ = _run(look, 5.0, since=None)
    assert all(w is None for w in commands) and look.turns_started == 0
    _run(look, 20.0, since=0.0)
    assert look.turns_started == 1 and not look.turning
    commands, _, _ = _run(look, 2.0, since=0.0, t0=20.0)  # the same attempt: done
    assert all(w is None for w in commands)
    commands, _, _ = _run(look, 2.0, since=20.0, t0=20.0)  # a new search attempt
    assert look.turns_started == 2 and commands[-1] is not None


@pytest.mark.parametrize("blocker", ["emergency stop", "paused", "manual control (Tablet)"])
def test_never_turns_while_forbidden_nor_by_itself_after_it_clears(blocker: str) -> None:
    look = LookAround()
    commands, now, _ = _run(look, 3.0, blocker=blocker)
    assert all(w is None for w in commands) and look.turns_started == 0
    assert look.end_reason == f"not started: {blocker}"
    commands, _, _ = _run(look, 5.0, t0=now)  # the block is gone: this attempt stays still
    assert all(w is None for w in commands) and look.turns_started == 0


def test_a_block_while_turning_stops_the_turn_for_this_attempt() -> None:
    look = LookAround()
    commands, now, yaw = _run(look, 3.0)
    assert look.turning and commands[-1] is not None
    commands, now, yaw = _run(look, 1.0, blocker="emergency stop", t0=now, yaw0=yaw)
    assert all(w is None for w in commands) and not look.turning
    assert look.end_reason == "stopped: emergency stop"
    commands, _, _ = _run(look, 5.0, t0=now, yaw0=yaw)
    assert all(w is None for w in commands)


def test_disabled_never_turns() -> None:
    look = LookAround(LookAroundConfig(enabled=False))
    commands, _, _ = _run(look, 20.0)
    assert all(w is None for w in commands) and look.turns_started == 0


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("angular_speed", 0.0),
        ("angular_speed", 3.0),
        ("max_turn_rad", 7.0),
        ("start_after_s", -1),
        ("stall_s", 0.0),
        ("stall_rad", -0.1),
    ],
)
def test_config_out_of_range_is_refused_naming_the_field(field: str, value: float) -> None:
    with pytest.raises(LookAroundConfigError, match=field):
        LookAroundConfig(**{field: value})  # type: ignore[arg-type]


def test_a_turn_that_does_not_happen_is_ended_and_said() -> None:
    """Commanded but the odometry heading does not move (wedged, held by the collision
    monitor): after ``stall_s`` the policy stops commanding and says why, rather than
    report "turning" for the rest of the search."""
    cfg = LookAroundConfig(angular_speed=0.5, start_after_s=0.5, stall_s=3.0)
    look = LookAround(cfg)
    commands: list[float | None] = []
    now = 0.0
    for _ in range(100):
        commands.append(look.update(0.0, 0.2, None, now))  # the heading never changes
        now = round(now + DT, 9)
    turning = [k for k, w in enumerate(commands) if w is not None]
    assert turning and turning[0] == 5
    assert (turning[-1] - turning[0]) * DT == pytest.approx(cfg.stall_s, abs=2 * DT)
    assert not look.turning and "does not turn" in look.end_reason and look.stalled
    assert commands[-1] is None  # and it does not start again in this attempt


def test_a_slow_but_real_turn_is_not_taken_for_a_stall() -> None:
    look = LookAround(LookAroundConfig(angular_speed=0.05, stall_s=3.0, stall_rad=0.1))
    commands, _, yaw = _run(look, 20.0)
    assert look.turning and commands[-1] == pytest.approx(0.05)
    assert yaw > 0.8
