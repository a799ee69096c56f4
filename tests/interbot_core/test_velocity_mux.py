"""Tests for interbot_core.velocity_mux: twist_mux's own cases, the gaps, and a reference model."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import hypothesis.strategies as st
import pytest
from hypothesis import HealthCheck, settings
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from interbot_core.velocity_mux import (
    DEFAULT_MUX_CONFIG,
    MuxConfig,
    MuxConfigError,
    MuxInput,
    MuxLock,
    UnknownTopicError,
    VelocityMux,
    load_mux_config,
    parse_mux_config,
)

RESOURCE = Path(__file__).resolve().parents[2] / "resources" / "config" / "twist_mux.yaml"


def two_inputs(timeout_hi: float = 0.5, timeout_lo: float = 0.5) -> MuxConfig:
    return MuxConfig(
        inputs=(
            MuxInput("joy", "joy_vel", timeout_hi, 100),
            MuxInput("nav", "nav_vel", timeout_lo, 10),
        ),
        locks=(),
    )


# --------------------------------------------------------------------- twist_mux's own cases


def test_no_input_gives_explicit_zero_and_no_source() -> None:
    mux = VelocityMux(two_inputs())
    out = mux.output(0.0)
    assert (out.linear, out.angular, out.source) == (0.0, 0.0, None)
    assert out.reason == "no valid input"
    assert out.active_locks == ()


def test_one_input_passes_through() -> None:
    mux = VelocityMux(two_inputs())
    mux.on_twist("nav_vel", 0.3, -0.2, now=1.0)
    out = mux.output(1.1)
    assert (out.linear, out.angular, out.source) == (0.3, -0.2, "nav")
    assert out.reason == "input nav"


def test_higher_priority_overrides_and_lower_returns_after_timeout() -> None:
    mux = VelocityMux(two_inputs(timeout_hi=0.5, timeout_lo=0.0))
    mux.on_twist("nav_vel", 0.3, 0.0, now=0.0)
    mux.on_twist("joy_vel", -0.1, 0.5, now=1.0)
    assert mux.output(1.0).source == "joy"
    assert mux.output(1.5).source == "joy"  # exactly at the timeout: not yet expired (strict >)
    out = mux.output(1.5001)
    assert (out.source, out.linear) == ("nav", 0.3)


# --------------------------------------------------------------------- the gaps


def test_timeout_zero_never_expires_but_needs_a_first_message() -> None:
    mux = VelocityMux(two_inputs(timeout_lo=0.0))
    assert mux.output(0.0).source is None
    mux.on_twist("nav_vel", 0.2, 0.0, now=0.0)
    assert mux.output(1e6).source == "nav"


def test_input_expires_strictly_after_timeout_and_gives_zero() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_twist("planner_vel", 0.4, 0.1, now=0.0)
    assert mux.output(0.05).source == "planner_vel"  # 0.05 - 0.0 == 0.05: not expired
    out = mux.output(0.0501)
    assert (out.linear, out.angular, out.source, out.reason) == (0.0, 0.0, None, "no valid input")


def test_lock_dead_man_is_active_while_silent() -> None:
    config = MuxConfig(
        inputs=(MuxInput("nav", "nav_vel", 0.0, 10),),
        locks=(MuxLock("heartbeat", "hb", 0.2, 20),),
    )
    mux = VelocityMux(config)
    mux.on_twist("nav_vel", 0.5, 0.0, now=0.0)
    # Before its first message a dead-man lock is active (twist_mux: stamp 0).
    assert mux.output(0.0).source is None
    assert mux.output(0.0).active_locks == ("heartbeat",)
    mux.on_lock("hb", False, now=1.0)
    assert mux.output(1.2).source == "nav"
    out = mux.output(1.21)  # silent for more than 0.2 s
    assert out.source is None
    assert out.reason.startswith("masked by lock hb")
    mux.on_lock("hb", False, now=1.3)
    assert mux.output(1.3).source == "nav"


def test_lock_engaging_mid_command_zeroes_output_and_release_restores() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    for k in range(5):
        mux.on_twist("planner_vel", 0.5, 0.0, now=k * 0.02)
        assert mux.output(k * 0.02).source == "planner_vel"
    mux.on_lock("pause_nav", True, now=0.09)
    mux.on_twist("planner_vel", 0.5, 0.0, now=0.1)
    out = mux.output(0.1)
    assert (out.linear, out.angular, out.source) == (0.0, 0.0, None)
    assert "pause_nav" in out.reason
    assert out.active_locks == ("Pause Navigation",)
    mux.on_lock("pause_nav", False, now=0.11)
    mux.on_twist("planner_vel", 0.5, 0.0, now=0.12)
    assert mux.output(0.12).source == "planner_vel"  # pause does not latch


def test_equal_priority_with_lock_passes() -> None:
    config = MuxConfig(
        inputs=(MuxInput("a", "a", 0.0, 50), MuxInput("b", "b", 0.0, 49)),
        locks=(MuxLock("l", "l", 0.0, 50),),
    )
    mux = VelocityMux(config)
    mux.on_lock("l", True, now=0.0)
    mux.on_twist("b", 1.0, 0.0, now=0.0)
    assert mux.output(0.0).source is None  # 49 < 50: masked
    mux.on_twist("a", 2.0, 0.0, now=0.0)
    assert mux.output(0.0).source == "a"  # 50 == 50: passes


def test_thesis_pause_masks_only_planner() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_lock("pause_nav", True, now=0.0)
    mux.on_twist("planner_vel", 0.5, 0.0, now=0.0)
    assert mux.output(0.0).source is None
    mux.on_twist("tablet_vel", 0.2, 0.1, now=0.0)
    assert mux.output(0.0).source == "tablet_vel"
    mux.on_twist("station_vel", 0.1, 0.0, now=0.0)
    assert mux.output(0.0).source == "station_vel"


def test_thesis_stop_masks_everything_and_latches_until_release() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_lock("stop", True, now=0.0)
    for topic in ("station_vel", "tablet_vel", "planner_vel"):
        mux.on_twist(topic, 0.5, 0.5, now=0.0)
    out = mux.output(0.0)
    assert (out.linear, out.angular, out.source) == (0.0, 0.0, None)
    assert out.reason == "masked by lock stop ('Emergency Stop', priority 255)"
    mux.on_lock("stop", False, now=0.1)  # a false message does not release a latched stop
    mux.on_twist("station_vel", 0.5, 0.5, now=0.1)
    assert mux.output(0.1).source is None
    assert mux.latched_locks() == ("stop",)
    assert mux.release_stop() == ("stop",)
    assert mux.latched_locks() == ()
    assert mux.output(0.1).source == "station_vel"
    assert mux.release_stop() == ()


def test_stop_without_inputs_reports_mask_not_missing_input() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_lock("stop", True, now=0.0)
    assert mux.output(0.0).reason.startswith("masked by lock stop")


def test_release_while_still_engaged_keeps_lock_active() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_lock("stop", True, now=0.0)
    mux.release_stop()
    mux.on_twist("station_vel", 0.5, 0.0, now=0.0)
    assert mux.output(0.0).source is None  # last value still true
    mux.on_lock("stop", False, now=0.1)
    mux.on_twist("station_vel", 0.5, 0.0, now=0.1)
    assert mux.output(0.1).source == "station_vel"


def test_latching_is_configurable() -> None:
    config = MuxConfig(
        inputs=DEFAULT_MUX_CONFIG.inputs, locks=DEFAULT_MUX_CONFIG.locks, latching_locks=()
    )
    mux = VelocityMux(config)
    mux.on_lock("stop", True, now=0.0)
    mux.on_lock("stop", False, now=0.1)
    mux.on_twist("planner_vel", 0.1, 0.0, now=0.1)
    assert mux.output(0.1).source == "planner_vel"
    latch_pause = MuxConfig(
        inputs=DEFAULT_MUX_CONFIG.inputs,
        locks=DEFAULT_MUX_CONFIG.locks,
        latching_locks=("pause_nav",),
    )
    mux = VelocityMux(latch_pause)
    mux.on_lock("pause_nav", True, now=0.0)
    mux.on_lock("pause_nav", False, now=0.01)
    mux.on_twist("planner_vel", 0.1, 0.0, now=0.02)
    assert mux.output(0.02).source is None
    assert mux.release_stop() == ("pause_nav",)


def test_active_source_and_locks_report() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    mux.on_lock("pause_nav", True, now=0.0)
    mux.on_lock("stop", True, now=0.0)
    mux.on_twist("tablet_vel", 0.3, 0.0, now=0.0)
    assert mux.output(0.0).active_locks == ("Emergency Stop", "Pause Navigation")
    assert [i.name for i in mux.valid_inputs(0.0)] == ["tablet_vel"]
    assert [lk.topic for lk in mux.active_locks(0.0)] == ["stop", "pause_nav"]
    mux.release_stop()
    mux.on_lock("stop", False, now=0.0)
    out = mux.output(0.0)
    assert (out.source, out.active_locks) == ("tablet_vel", ("Pause Navigation",))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_velocity_is_ignored_and_counted(bad: float) -> None:
    mux = VelocityMux(two_inputs())
    mux.on_twist("joy_vel", 0.2, 0.1, now=0.0)
    assert mux.on_twist("joy_vel", bad, 0.0, now=0.3) is False
    assert mux.on_twist("joy_vel", 0.0, bad, now=0.3) is False
    assert mux.rejected_count == 2
    out = mux.output(0.3)
    assert (out.linear, out.angular, out.source) == (0.2, 0.1, "joy")
    assert mux.output(0.51).source is None  # the rejected message did not refresh the stamp


def test_unknown_topics_raise() -> None:
    mux = VelocityMux(DEFAULT_MUX_CONFIG)
    with pytest.raises(UnknownTopicError, match="'cmd_vel' is not a mux input topic"):
        mux.on_twist("cmd_vel", 0.0, 0.0, now=0.0)
    with pytest.raises(UnknownTopicError, match="not a mux lock topic"):
        mux.on_lock("station_vel", True, now=0.0)
    with pytest.raises(ValueError, match="finite"):
        mux.output(math.nan)


# --------------------------------------------------------------------- configuration


def test_resource_file_equals_thesis_default() -> None:
    assert load_mux_config(RESOURCE) == DEFAULT_MUX_CONFIG


def test_thesis_default_values() -> None:
    by_topic = {i.topic: (i.priority, i.timeout) for i in DEFAULT_MUX_CONFIG.inputs}
    assert by_topic == {
        "station_vel": (100, 0.5),
        "tablet_vel": (50, 0.5),
        "planner_vel": (10, 0.05),
    }
    locks = {lk.topic: (lk.priority, lk.timeout) for lk in DEFAULT_MUX_CONFIG.locks}
    assert locks == {"pause_nav": (25, 0.0), "stop": (255, 0.0)}
    assert DEFAULT_MUX_CONFIG.latching_locks == ("stop",)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"priority": 0}, "priority = 0 is outside the allowed range 1..255"),
        ({"priority": 256}, "priority = 256 is outside the allowed range 1..255"),
        ({"priority": 2.5}, "must be an integer"),
        ({"priority": True}, "must be an integer"),
        ({"timeout": -0.1}, r"timeout = -0.1 s is outside the allowed range \[0, inf\) s"),
        ({"timeout": math.inf}, r"timeout must be a finite number \[s\], got inf"),
        ({"timeout": math.nan}, r"timeout must be a finite number \[s\], got nan"),
        ({"timeout": "0.5"}, "must be a number"),
        ({"topic": ""}, "topic must be a non-empty string"),
        ({"name": ""}, "name must be a non-empty string"),
    ],
)
@pytest.mark.parametrize("kind", [MuxInput, MuxLock])
def test_entry_validation(
    kind: type[MuxInput] | type[MuxLock], kwargs: dict[str, object], message: str
) -> None:
    args: dict[str, object] = {"name": "x", "topic": "x", "timeout": 0.5, "priority": 10}
    args.update(kwargs)
    with pytest.raises(MuxConfigError, match=message):
        kind(**args)  # type: ignore[arg-type]


def test_config_validation() -> None:
    a = MuxInput("a", "a_vel", 0.5, 10)
    with pytest.raises(MuxConfigError, match="at least one input"):
        MuxConfig(inputs=())
    with pytest.raises(MuxConfigError, match=r"'a' and 'b' have the same priority 10"):
        MuxConfig(inputs=(a, MuxInput("b", "b_vel", 0.5, 10)))
    with pytest.raises(MuxConfigError, match=r"'p' and 'q' have the same priority 25"):
        MuxConfig(inputs=(a,), locks=(MuxLock("p", "p", 0, 25), MuxLock("q", "q", 0, 25)))
    with pytest.raises(MuxConfigError, match="same topic 'a_vel'"):
        MuxConfig(inputs=(a, MuxInput("b", "a_vel", 0.5, 11)))
    with pytest.raises(MuxConfigError, match="same name 'a'"):
        MuxConfig(inputs=(a, MuxInput("a", "b_vel", 0.5, 11)))
    with pytest.raises(MuxConfigError, match="same topic 'a_vel'"):
        MuxConfig(inputs=(a,), locks=(MuxLock("l", "a_vel", 0, 25),))
    with pytest.raises(MuxConfigError, match="latching lock 'nope' is not a configured lock"):
        MuxConfig(inputs=(a,), latching_locks=("nope",))
    # An input and a lock may share a priority; the default latch needs no stop lock.
    assert MuxConfig(inputs=(a,), locks=(MuxLock("l", "l", 0, 10),)).latching_locks == ("stop",)


def test_parse_name_defaults_to_topic_and_ros2_form() -> None:
    config = parse_mux_config(
        {"topics": [{"topic": "t", "timeout": 1, "priority": 3}], "locks": None}
    )
    assert config.inputs == (MuxInput("t", "t", 1.0, 3),)
    ros2 = parse_mux_config(
        {
            "twist_mux": {
                "ros__parameters": {
                    "topics": {"joy": {"topic": "joy_vel", "timeout": 0.5, "priority": 100}},
                    "locks": {"e_stop": {"topic": "e_stop", "timeout": 0.0, "priority": 255}},
                }
            }
        }
    )
    assert ros2.inputs == (MuxInput("joy", "joy_vel", 0.5, 100),)
    assert ros2.locks == (MuxLock("e_stop", "e_stop", 0.0, 255),)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("topics:\n  - {topic: a, timeout: 0.5}\n", r"topics\[0\]\.priority is missing"),
        (
            "topics:\n  - {topic: a, timeout: 0.5, priority: 300}\n",
            r"topics\[0\]\.priority = 300 is outside the allowed range 1..255",
        ),
        (
            "topics:\n  - {topic: a, timeout: 0.5, priority: 3}\n"
            "locks:\n  - {name: L, topic: l, timeout: -1, priority: 3}\n",
            r"locks\[0\]\.timeout = -1 s is outside the allowed range \[0, inf\) s",
        ),
        (
            "topics:\n  - {topic: a, timeout: 0.5, priority: 3, prio: 4}\n",
            r"topics\[0\]\.prio is not a field",
        ),
        ("locks: []\n", "no 'topics:' list"),
        ("topics: [a]\n", r"topics\[0\] must be a mapping"),
        ("topics: {{\n", "invalid YAML"),
        ("topic:\n  - {topic: a, timeout: 0.5, priority: 3}\n", "unknown top-level keys"),
        (
            "topics:\n  - {topic: a, timeout: 0.5, priority: 3}\n"
            "  - {topic: b, timeout: 0.5, priority: 3}\n",
            "'a' and 'b' have the same priority 3",
        ),
    ],
)
def test_load_errors_name_file_and_entry(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "mux.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(MuxConfigError, match=message) as info:
        load_mux_config(path)
    assert str(path) in str(info.value)


def test_load_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MuxConfigError, match="cannot read"):
        load_mux_config(tmp_path / "absent.yaml")


# --------------------------------------------------------------------- reference model


@dataclass
class ReferenceMux:
    """The rules written as plainly as possible, to check VelocityMux against."""

    config: MuxConfig
    twists: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    locks: dict[str, tuple[float, bool]] = field(default_factory=dict)
    latched: set[str] = field(default_factory=set)

    def twist(self, topic: str, linear: float, angular: float, now: float) -> None:
        if math.isfinite(linear) and math.isfinite(angular):
            self.twists[topic] = (now, linear, angular)

    def lock(self, topic: str, value: bool, now: float) -> None:
        self.locks[topic] = (now, value)
        if value and topic in self.config.latching_locks:
            self.latched.add(topic)

    def lock_is_active(self, lock: MuxLock, now: float) -> bool:
        if lock.topic in self.latched:
            return True
        if lock.topic not in self.locks:
            return lock.timeout > 0
        stamp, value = self.locks[lock.topic]
        return value or (lock.timeout > 0 and now - stamp > lock.timeout)

    def output(self, now: float) -> tuple[float, float, str | None]:
        lock_priority = 0
        for lock in self.config.locks:
            if self.lock_is_active(lock, now):
                lock_priority = max(lock_priority, lock.priority)
        best: MuxInput | None = None
        for entry in self.config.inputs:
            if entry.topic not in self.twists:
                continue
            stamp = self.twists[entry.topic][0]
            if entry.timeout > 0 and now - stamp > entry.timeout:
                continue
            if entry.priority < lock_priority:
                continue
            if best is None or entry.priority > best.priority:
                best = entry
        if best is None:
            return (0.0, 0.0, None)
        _, linear, angular = self.twists[best.topic]
        return (linear, angular, best.name)


@st.composite
def mux_configs(draw: st.DrawFn) -> MuxConfig:
    timeouts = st.sampled_from([0.0, 0.05, 0.2, 0.5])
    n_inputs = draw(st.integers(1, 4))
    n_locks = draw(st.integers(0, 3))
    in_prios = draw(
        st.lists(st.integers(1, 255), min_size=n_inputs, max_size=n_inputs, unique=True)
    )
    lk_prios = draw(st.lists(st.integers(1, 255), min_size=n_locks, max_size=n_locks, unique=True))
    inputs = tuple(MuxInput(f"in{i}", f"in{i}", draw(timeouts), p) for i, p in enumerate(in_prios))
    locks = tuple(MuxLock(f"lk{i}", f"lk{i}", draw(timeouts), p) for i, p in enumerate(lk_prios))
    latching = tuple(lk.topic for lk in locks if draw(st.booleans()))
    return MuxConfig(inputs, locks, latching)


class MuxMachine(RuleBasedStateMachine):
    """Random sequences of twists, locks, releases and time steps: mux == reference."""

    def __init__(self) -> None:
        super().__init__()
        self.now = 0.0

    @initialize(config=mux_configs())
    def setup(self, config: MuxConfig) -> None:
        self.mux = VelocityMux(config)
        self.ref = ReferenceMux(config)

    @rule(
        data=st.data(),
        linear=st.one_of(st.floats(-2, 2), st.sampled_from([math.nan, math.inf])),
        angular=st.floats(-2, 2),
    )
    def twist(self, data: st.DataObject, linear: float, angular: float) -> None:
        topic = data.draw(st.sampled_from([i.topic for i in self.mux.config.inputs]))
        self.mux.on_twist(topic, linear, angular, self.now)
        self.ref.twist(topic, linear, angular, self.now)

    @rule(data=st.data(), value=st.booleans())
    def lock(self, data: st.DataObject, value: bool) -> None:
        if not self.mux.config.locks:
            return
        topic = data.draw(st.sampled_from([lk.topic for lk in self.mux.config.locks]))
        self.mux.on_lock(topic, value, self.now)
        self.ref.lock(topic, value, self.now)

    @rule()
    def release(self) -> None:
        self.mux.release_stop()
        self.ref.latched.clear()

    @rule(dt=st.one_of(st.sampled_from([0.0, 0.05, 0.2, 0.5]), st.floats(0.0, 0.7)))
    def advance(self, dt: float) -> None:
        self.now += dt

    @invariant()
    def matches_reference(self) -> None:
        if not hasattr(self, "mux"):
            return
        out = self.mux.output(self.now)
        assert (out.linear, out.angular, out.source) == self.ref.output(self.now)
        if out.source is None:
            assert out.reason in ("no valid input",) or out.reason.startswith("masked by lock")


MuxMachine.TestCase.settings = settings(
    max_examples=150,
    stateful_step_count=30,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
TestMuxAgainstReference = MuxMachine.TestCase


# ------------------------------------------------------------------ per-source limits (issue 11)
def test_each_source_is_limited_on_the_robot_keeping_the_curvature() -> None:
    from robot_daemon.config import DEFAULT_MUX

    config = load_mux_config(DEFAULT_MUX)
    tablet = config.input_by_topic("tablet_vel")
    assert (tablet.max_linear, tablet.max_angular) == (0.3, 1.0)
    assert all(math.isfinite(i.max_linear) for i in config.inputs)
    mux = VelocityMux(config)
    mux.on_twist("tablet_vel", 1.0, 0.5, 0.0)  # the thesis issue: 1.0 m/s from the tablet
    out = mux.output(0.1)
    assert out.linear == pytest.approx(0.3) and out.angular == pytest.approx(0.15)
    assert "limited to 0.3 m/s" in out.reason
    mux.on_twist("tablet_vel", -0.1, -2.0, 0.2)  # angular bound binds
    out = mux.output(0.2)
    assert out.angular == pytest.approx(-1.0) and out.linear == pytest.approx(-0.05)
    mux.on_twist("tablet_vel", 0.2, 0.1, 0.3)  # within: untouched
    assert (mux.output(0.3).linear, mux.output(0.3).reason) == (0.2, "input Tablet")


def test_limits_in_yaml_are_validated() -> None:
    base = {"topics": [{"name": "a", "topic": "a", "timeout": 0.5, "priority": 1}]}
    base["topics"][0]["max_linear"] = -1.0
    with pytest.raises(MuxConfigError, match=r"max_linear = -1.0 m/s is outside .* \(0, inf\)"):
        parse_mux_config(base)
    base["topics"][0]["max_linear"] = "fast"
    with pytest.raises(MuxConfigError, match="max_linear must be a number"):
        parse_mux_config(base)
    lock = {"name": "s", "topic": "s", "timeout": 0.0, "priority": 2, "max_linear": 1.0}
    with pytest.raises(MuxConfigError, match=r"locks\[0\]\.max_linear is not a field"):
        parse_mux_config({"topics": [{"topic": "a", "timeout": 0, "priority": 1}], "locks": [lock]})
