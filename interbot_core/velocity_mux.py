"""Priority velocity multiplexer with locks: twist_mux semantics (thesis §5.4.1.1, Listings 5.3/5.4).

Reference: ros-teleop/twist_mux (``twist_mux.cpp``, ``topic_handle.hpp``). The rules are
twist_mux's, exactly:

* an input is *masked* when ``priority < highest active lock priority`` (strict: an input whose
  priority equals the lock's passes);
* an input is *expired* when ``timeout > 0 and now - stamp > timeout``; ``timeout == 0`` never
  expires; an input is expired before its first message;
* a lock is *active* when its last value is true, or when ``timeout > 0`` and it has been silent
  for longer than ``timeout`` (a dead-man; also before its first message, as twist_mux's zero
  stamp makes it);
* the highest-priority input that is neither masked nor expired wins.

What we do beyond twist_mux (see shared/FIELD_NOTES.md):

* ``output(now)`` always returns a command. When no input is valid, or a lock masks every valid
  input, the command is an explicit zero with ``source=None`` and a reason. twist_mux instead
  publishes only when the winning input's message arrives, so a robot keeps its last speed
  when inputs expire or a lock engages.
* Locks listed in ``MuxConfig.latching_locks`` (default: the ``stop`` lock) *latch*: once a true
  message engages one it stays active, even after a false message, until ``release_stop()``.
  A latching lock that is active only as a dead-man (silence) does not latch: its heartbeat
  coming back is the recovery.
* Non-finite velocities are rejected: the message is ignored (counted in ``rejected_count``) and
  the input keeps its previous command and stamp.
* One speed limit per source (issue 11): an input may carry ``max_linear`` [m/s] and
  ``max_angular`` [rad/s] (our YAML extension, default unlimited). A command beyond them is
  scaled down as a whole, ``s = min(1, max_linear/|v|, max_angular/|w|)``, so the robot keeps
  the commanded curvature (path) and only slows down; the output's reason says so. The robot
  enforces its limits whatever a user interface offers.

Times are monotonic seconds passed in by the caller; nothing here reads a clock.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, ClassVar

from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import SchemaError

logger = logging.getLogger(__name__)

PRIORITY_MIN = 1
PRIORITY_MAX = 255
DEFAULT_LATCHING_LOCKS: tuple[str, ...] = ("stop",)


class MuxError(Exception):
    """Base class for velocity multiplexer errors."""


class MuxConfigError(MuxError, ValueError):
    """The multiplexer configuration is invalid; the message names the file and entry."""


class UnknownTopicError(MuxError, KeyError):
    """A message arrived on a topic that is not configured as an input (or lock)."""

    def __str__(self) -> str:  # KeyError would quote the whole message
        return str(self.args[0]) if self.args else ""


Priority = Annotated[int, Meta(ge=PRIORITY_MIN, le=PRIORITY_MAX)]
Timeout = Annotated[float, Meta(ge=0.0, le=schema.FINITE, extra={"unit": "s"})]  # 0: never
Label = Annotated[str, Meta(pattern=r"\S", extra={"format": "a non-empty string"})]
SpeedLimit = Annotated[float, Meta(gt=0.0, extra={"unit": "m/s"})]  # inf: no limit
TurnLimit = Annotated[float, Meta(gt=0.0, extra={"unit": "rad/s"})]


class _Entry(schema.Declared, frozen=True):
    """An input or a lock; errors say which: ``input 'x': priority = 0 is outside ...``."""

    ERROR: ClassVar[type[Exception]] = MuxConfigError
    KIND: ClassVar[str] = ""

    def __post_init__(self) -> None:
        if schema.decoding():
            return
        try:
            schema.check_fields(self, "")
        except SchemaError as exc:
            raise MuxConfigError(f"{self.KIND} {self.name!r}: {exc.message}") from None

    @property
    def name(self) -> str:  # pragma: no cover - every entry declares it
        raise NotImplementedError


class MuxInput(_Entry, frozen=True):
    """One velocity input: ``timeout`` [s] (0 = never expires), ``priority`` 1..255 (higher wins),
    speed limits ``max_linear`` [m/s] and ``max_angular`` [rad/s] (default: none)."""

    KIND: ClassVar[str] = "input"
    name: Label  # type: ignore[assignment]
    topic: Label
    timeout: Timeout
    priority: Priority
    max_linear: SpeedLimit = math.inf
    max_angular: TurnLimit = math.inf

    def limit(self, linear: float, angular: float) -> tuple[float, float, bool]:
        """The command scaled into the limits (same curvature); True if it was scaled."""
        scale = 1.0
        if abs(linear) > self.max_linear:
            scale = self.max_linear / abs(linear)
        if abs(angular) > self.max_angular:
            scale = min(scale, self.max_angular / abs(angular))
        if scale >= 1.0:
            return linear, angular, False
        return linear * scale, angular * scale, True


class MuxLock(_Entry, frozen=True):
    """One lock: while active it masks inputs of lower priority. ``timeout`` > 0 is a dead-man [s]."""

    KIND: ClassVar[str] = "lock"
    name: Label  # type: ignore[assignment]
    topic: Label
    timeout: Timeout
    priority: Priority


def _check_unique(kind: str, entries: Iterable[MuxInput | MuxLock], attr: str) -> None:
    seen: dict[object, str] = {}
    for entry in entries:
        key = getattr(entry, attr)
        if key in seen:
            raise MuxConfigError(
                f"{kind} {seen[key]!r} and {entry.name!r} have the same {attr} {key!r}; "
                f"each {attr} must be unique"
            )
        seen[key] = entry.name


@dataclass(frozen=True, slots=True)
class MuxConfig:
    """The multiplexer's inputs and locks (twist_mux ``topics:`` and ``locks:``).

    ``latching_locks`` lists lock *topics* that latch (stay active until ``release_stop()``).
    Each entry must name a configured lock, except the default ``"stop"``, which simply has no
    effect in a configuration without a ``stop`` lock.
    """

    inputs: tuple[MuxInput, ...]
    locks: tuple[MuxLock, ...] = ()
    latching_locks: tuple[str, ...] = DEFAULT_LATCHING_LOCKS

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs", tuple(self.inputs))
        object.__setattr__(self, "locks", tuple(self.locks))
        object.__setattr__(self, "latching_locks", tuple(self.latching_locks))
        if not self.inputs:
            raise MuxConfigError("mux config: at least one input topic is required")
        for entry in self.inputs:
            if not isinstance(entry, MuxInput):
                raise MuxConfigError(f"mux config: inputs must be MuxInput, got {entry!r}")
        for lock in self.locks:
            if not isinstance(lock, MuxLock):
                raise MuxConfigError(f"mux config: locks must be MuxLock, got {lock!r}")
        _check_unique("inputs", self.inputs, "priority")
        _check_unique("locks", self.locks, "priority")
        everything: tuple[MuxInput | MuxLock, ...] = (*self.inputs, *self.locks)
        _check_unique("entries", everything, "name")
        _check_unique("entries", everything, "topic")
        lock_topics = {lock.topic for lock in self.locks}
        if len(set(self.latching_locks)) != len(self.latching_locks):
            raise MuxConfigError(
                f"mux config: latching_locks has duplicates: {self.latching_locks}"
            )
        for topic in self.latching_locks:
            if topic not in lock_topics and topic not in DEFAULT_LATCHING_LOCKS:
                raise MuxConfigError(
                    f"mux config: latching lock {topic!r} is not a configured lock topic "
                    f"(locks: {sorted(lock_topics)})"
                )

    def input_by_topic(self, topic: str) -> MuxInput:
        for entry in self.inputs:
            if entry.topic == topic:
                return entry
        raise UnknownTopicError(
            f"{topic!r} is not a mux input topic (inputs: {[i.topic for i in self.inputs]})"
        )

    def lock_by_topic(self, topic: str) -> MuxLock:
        for lock in self.locks:
            if lock.topic == topic:
                return lock
        raise UnknownTopicError(
            f"{topic!r} is not a mux lock topic (locks: {[lk.topic for lk in self.locks]})"
        )


#: Thesis Listings 5.3 (topics) and 5.4 (locks), used for most of the Chapter 6 tests.
DEFAULT_MUX_CONFIG = MuxConfig(
    inputs=(
        MuxInput(name="station_vel", topic="station_vel", timeout=0.5, priority=100),
        MuxInput(name="tablet_vel", topic="tablet_vel", timeout=0.5, priority=50),
        MuxInput(name="planner_vel", topic="planner_vel", timeout=0.05, priority=10),
    ),
    locks=(
        MuxLock(name="Pause Navigation", topic="pause_nav", timeout=0.0, priority=25),
        MuxLock(name="Emergency Stop", topic="stop", timeout=0.0, priority=255),
    ),
)


# --------------------------------------------------------------------------- YAML loading


def _entries(raw: object, key: str, source: str) -> list[tuple[str, Mapping[str, Any]]]:
    """Normalise a ``topics:``/``locks:`` value to ``[(label, mapping)]``.

    Accepts twist_mux's ROS 1 list form (``- {name, topic, timeout, priority}``) and its ROS 2
    mapping form (``name: {topic, timeout, priority}``).
    """
    if raw is None:
        return []
    if isinstance(raw, list):
        out: list[tuple[str, Mapping[str, Any]]] = []
        for index, item in enumerate(raw):
            if not isinstance(item, Mapping):
                raise MuxConfigError(
                    f"{source}: {key}[{index}] must be a mapping with name/topic/timeout/priority,"
                    f" got {item!r}"
                )
            out.append((f"{key}[{index}]", item))
        return out
    if isinstance(raw, Mapping):
        out = []
        for name, item in raw.items():
            if not isinstance(item, Mapping):
                raise MuxConfigError(
                    f"{source}: {key}.{name} must be a mapping with topic/timeout/priority,"
                    f" got {item!r}"
                )
            out.append((f"{key}.{name}", {"name": str(name), **item}))
        return out
    raise MuxConfigError(f"{source}: {key} must be a list of entries, got {type(raw).__name__}")


def _parse_entry(
    kind: type[MuxInput] | type[MuxLock], label: str, item: Mapping[str, Any], source: str
) -> MuxInput | MuxLock:
    fields = {k: v for k, v in item.items() if k != "short_desc"}  # twist_mux's, unused
    if "topic" in fields:
        fields.setdefault("name", fields["topic"])
    try:
        return schema.convert(fields, kind, label)
    except SchemaError as exc:
        raise MuxConfigError(f"{source}: {exc.message}") from None


def parse_mux_config(data: Mapping[str, Any], source: str = "<mux config>") -> MuxConfig:
    """Build a `MuxConfig` from parsed twist_mux YAML (``topics:``, ``locks:``).

    A ROS 2 parameter file (``<node>: {ros__parameters: {...}}``) is unwrapped. An optional
    ``latching_locks:`` list (our extension) overrides the default ``[stop]``.
    """
    if not isinstance(data, Mapping):
        raise MuxConfigError(f"{source}: expected a mapping with 'topics' and 'locks'")
    if "topics" not in data and len(data) == 1:
        (inner,) = data.values()
        if isinstance(inner, Mapping) and isinstance(inner.get("ros__parameters"), Mapping):
            data = inner["ros__parameters"]
    unknown = set(data) - {"topics", "locks", "latching_locks"}
    if unknown:
        raise MuxConfigError(
            f"{source}: unknown top-level keys {sorted(unknown)} "
            f"(allowed: topics, locks, latching_locks)"
        )
    if "topics" not in data:
        raise MuxConfigError(f"{source}: no 'topics:' list; at least one input is required")
    inputs = [
        _parse_entry(MuxInput, label, item, source)
        for label, item in _entries(data["topics"], "topics", source)
    ]
    locks = [
        _parse_entry(MuxLock, label, item, source)
        for label, item in _entries(data.get("locks"), "locks", source)
    ]
    latching = data.get("latching_locks", DEFAULT_LATCHING_LOCKS)
    if not isinstance(latching, list | tuple) or not all(isinstance(t, str) for t in latching):
        raise MuxConfigError(f"{source}: latching_locks must be a list of lock topics")
    try:
        return MuxConfig(
            inputs=tuple(i for i in inputs if isinstance(i, MuxInput)),
            locks=tuple(lk for lk in locks if isinstance(lk, MuxLock)),
            latching_locks=tuple(latching),
        )
    except MuxConfigError as exc:
        raise MuxConfigError(f"{source}: {exc}") from None


def load_mux_config(path: str | Path) -> MuxConfig:
    """Read a twist_mux YAML file (see ``resources/config/twist_mux.yaml``)."""
    data = schema.read_yaml(path, MuxConfigError, "mux config")
    config = parse_mux_config(data, str(path))
    logger.info(
        "mux config %s: inputs %s; locks %s; latching %s",
        path,
        ", ".join(f"{i.topic}(p{i.priority}, {i.timeout:g} s)" for i in config.inputs),
        ", ".join(f"{lk.topic}(p{lk.priority}, {lk.timeout:g} s)" for lk in config.locks),
        list(config.latching_locks),
    )
    return config


# --------------------------------------------------------------------------- the multiplexer


@dataclass(frozen=True, slots=True)
class MuxOutput:
    """The command to send: ``linear`` [m/s], ``angular`` [rad/s].

    ``source`` is the winning input's name, or None for an explicit zero; ``reason`` says why;
    ``active_locks`` names the active locks, highest priority first.
    """

    linear: float
    angular: float
    source: str | None
    reason: str
    active_locks: tuple[str, ...] = field(default=())


@dataclass(slots=True)
class _InputState:
    stamp: float | None = None
    linear: float = 0.0
    angular: float = 0.0


@dataclass(slots=True)
class _LockState:
    stamp: float | None = None
    value: bool = False
    latched: bool = False


def _check_now(now: float) -> float:
    if not math.isfinite(now):
        raise ValueError(f"mux time must be finite seconds, got {now!r}")
    return float(now)


class VelocityMux:
    """Priority multiplexer over the configured inputs, masked by locks (twist_mux rules)."""

    def __init__(self, config: MuxConfig = DEFAULT_MUX_CONFIG) -> None:
        self.config = config
        self._inputs: dict[str, _InputState] = {i.topic: _InputState() for i in config.inputs}
        self._locks: dict[str, _LockState] = {lk.topic: _LockState() for lk in config.locks}
        self._latching = frozenset(config.latching_locks)
        self._rejected = 0

    @property
    def rejected_count(self) -> int:
        """Messages ignored because a velocity was not finite."""
        return self._rejected

    def on_twist(self, topic: str, linear: float, angular: float, now: float) -> bool:
        """A velocity message on ``topic``: ``linear`` [m/s], ``angular`` [rad/s].

        Returns False (and counts it) when a velocity is not finite: the message is ignored.
        """
        entry = self.config.input_by_topic(topic)
        now = _check_now(now)
        if not (math.isfinite(linear) and math.isfinite(angular)):
            self._rejected += 1
            logger.warning(
                "mux input %s: ignored non-finite command (%r, %r)", entry.name, linear, angular
            )
            return False
        state = self._inputs[topic]
        state.stamp, state.linear, state.angular = now, float(linear), float(angular)
        return True

    def on_lock(self, topic: str, engaged: bool, now: float) -> None:
        """A lock message on ``topic`` (true = engage). Latching locks stay engaged."""
        lock = self.config.lock_by_topic(topic)
        now = _check_now(now)
        state = self._locks[topic]
        state.stamp, state.value = now, bool(engaged)
        if engaged and topic in self._latching and not state.latched:
            state.latched = True
            logger.warning("mux lock %s (%s) engaged and latched", lock.name, topic)

    def release_stop(self) -> tuple[str, ...]:
        """Release every latched lock; returns the topics released.

        A released lock stays active while its last message is still true (or it is silent
        past its dead-man timeout).
        """
        released = tuple(t for t, s in self._locks.items() if s.latched)
        for topic in released:
            self._locks[topic].latched = False
        if released:
            logger.info("mux: released latched locks %s", list(released))
        return released

    def latched_locks(self) -> tuple[str, ...]:
        """Topics of the locks that are currently latched."""
        return tuple(t for t, s in self._locks.items() if s.latched)

    def _lock_active(self, lock: MuxLock, now: float) -> bool:
        state = self._locks[lock.topic]
        if state.latched or state.value:
            return True
        # twist_mux's dead-man: silent longer than the timeout (stamp 0 before any message).
        if lock.timeout > 0.0:
            return state.stamp is None or now - state.stamp > lock.timeout
        return False

    def _input_expired(self, entry: MuxInput, now: float) -> bool:
        stamp = self._inputs[entry.topic].stamp
        if stamp is None:
            return True
        return entry.timeout > 0.0 and now - stamp > entry.timeout

    def active_locks(self, now: float) -> tuple[MuxLock, ...]:
        """The active locks, highest priority first."""
        now = _check_now(now)
        active = [lk for lk in self.config.locks if self._lock_active(lk, now)]
        return tuple(sorted(active, key=lambda lk: lk.priority, reverse=True))

    def valid_inputs(self, now: float) -> tuple[MuxInput, ...]:
        """Inputs that have a message and have not expired, highest priority first."""
        now = _check_now(now)
        valid = [i for i in self.config.inputs if not self._input_expired(i, now)]
        return tuple(sorted(valid, key=lambda i: i.priority, reverse=True))

    def output(self, now: float) -> MuxOutput:
        """The command to publish at ``now``: the winning input's, or an explicit zero."""
        locks = self.active_locks(now)
        lock_names = tuple(lk.name for lk in locks)
        lock_priority = locks[0].priority if locks else 0
        valid = self.valid_inputs(now)
        for entry in valid:  # highest priority first
            if entry.priority < lock_priority:
                break  # this and every lower one are masked
            state = self._inputs[entry.topic]
            linear, angular, limited = entry.limit(state.linear, state.angular)
            reason = f"input {entry.name}"
            if limited:
                reason += f" (limited to {entry.max_linear:g} m/s, {entry.max_angular:g} rad/s)"
            return MuxOutput(linear, angular, entry.name, reason, lock_names)
        top_input = max(i.priority for i in self.config.inputs)
        if locks and (valid or lock_priority > top_input):
            top = locks[0]
            reason = f"masked by lock {top.topic} ({top.name!r}, priority {top.priority})"
        else:
            reason = "no valid input"
        return MuxOutput(0.0, 0.0, None, reason, lock_names)
