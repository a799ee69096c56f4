"""Controlling a replayed robot: the commands, the replay's state, and the replay clock.

A recording played back (``interbot replay FILE.mcap``) is a robot the station can watch; the
station's replay bar drives it with `ReplayCommand` (play, pause, speed ×0.5–×20, seek) on
``interbot-replay/<robot_id>/control`` and shows the `ReplayState` published on
``interbot-replay/<robot_id>/state``. The keys are outside ``interbot/**`` on purpose: a real
robot's link never sees them, and a station that knows nothing of replays is not disturbed.

`ReplayClock` maps wall time to recording time: ``position = anchor + (now - wall_anchor) * speed``
while playing, re-anchored at every play, pause, speed change and seek. Pure: ``now`` is passed in.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Final, TypeVar

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.topics import TopicDecodeError, validate_robot_id

T = TypeVar("T", bound=msgspec.Struct)

REPLAY_PREFIX: Final = "interbot-replay"
SPEED_MIN: Final = 0.5
SPEED_MAX: Final = 20.0
ACTIONS: Final = ("play", "pause", "speed", "seek")
MAX_PAYLOAD: Final = 1024


class ReplayError(ValueError):
    """A replay command or state that is malformed or out of range."""


def control_key(robot_id: str) -> str:
    return f"{REPLAY_PREFIX}/{validate_robot_id(robot_id)}/control"


def state_key(robot_id: str) -> str:
    return f"{REPLAY_PREFIX}/{validate_robot_id(robot_id)}/state"


STATE_WILDCARD: Final = f"{REPLAY_PREFIX}/*/state"


def robot_of_state_key(key_expr: str) -> str:
    parts = key_expr.split("/")
    if len(parts) != 3 or parts[0] != REPLAY_PREFIX or parts[2] != "state":
        raise ReplayError(f"{key_expr!r} is not a replay state key")
    return validate_robot_id(parts[1])


Speed = Annotated[float, Meta(ge=SPEED_MIN, le=SPEED_MAX)]
RecordingTime = Annotated[float, Meta(ge=0.0, le=1e9, extra={"unit": "s"})]


class ReplayCommand(schema.Declared, frozen=True):
    """``play`` / ``pause``; ``speed`` with value ×0.5–×20; ``seek`` with value [s] from the start."""

    ROOT: ClassVar[str] = "ReplayCommand"
    ERROR: ClassVar[type[Exception]] = ReplayError
    action: Annotated[str, schema.one_of(*ACTIONS)]
    value: RecordingTime = 0.0  # speed: a factor

    def check(self) -> None:
        if self.action == "speed":
            schema.checked(self.value, Speed, "speed", ReplayError)


class ReplayState(schema.Declared, frozen=True):
    """What the replay is doing: position and duration [s] of recording time."""

    ROOT: ClassVar[str] = "ReplayState"
    ERROR: ClassVar[type[Exception]] = ReplayError
    playing: bool
    speed: Speed
    position: RecordingTime  # from the recording's start
    duration: RecordingTime
    source: Annotated[str, Meta(max_length=256)] = ""  # the recording's file name

    def check(self) -> None:
        if self.position > self.duration:
            raise ReplayError(f"position {self.position} s is past the duration {self.duration} s")


def encode(message: ReplayCommand | ReplayState) -> bytes:
    return msgspec.json.encode(message)


def _decode(cls: type[T], payload: bytes) -> T:
    if len(payload) > MAX_PAYLOAD:
        raise TopicDecodeError(f"replay {cls.__name__}: {len(payload)} bytes > {MAX_PAYLOAD}")
    try:
        message = schema.convert(schema.parse_json(bytes(payload)), cls, cls.__name__)
        schema.check_all(message)
    except ValueError as exc:  # JsonSyntaxError, SchemaError, ReplayError
        raise TopicDecodeError(f"replay {cls.__name__}: {exc}") from None
    return message


def decode_command(payload: bytes) -> ReplayCommand:
    return _decode(ReplayCommand, payload)


def decode_state(payload: bytes) -> ReplayState:
    return _decode(ReplayState, payload)


class ReplayClock:
    """Recording time [s from the start] as a function of wall time ``now`` [s]."""

    def __init__(
        self, duration: float, now: float, *, speed: float = 1.0, playing: bool = True
    ) -> None:
        self.duration: float = schema.checked(duration, RecordingTime, "duration", ReplayError)
        self.speed: float = schema.checked(speed, Speed, "speed", ReplayError)
        self.playing = playing
        self._anchor = 0.0
        self._wall_anchor = now

    def position(self, now: float) -> float:
        if not self.playing:
            return self._anchor
        return min(self.duration, self._anchor + max(0.0, now - self._wall_anchor) * self.speed)

    @property
    def finished(self) -> bool:
        return self._anchor >= self.duration

    def _reanchor(self, now: float) -> None:
        self._anchor = self.position(now)
        self._wall_anchor = now

    def apply(self, command: ReplayCommand, now: float) -> None:
        """Carry out ``command``; a seek beyond the ends goes to the end it passed."""
        self._reanchor(now)
        if command.action == "play":
            if self._anchor >= self.duration:  # play at the end starts over
                self._anchor = 0.0
            self.playing = True
        elif command.action == "pause":
            self.playing = False
        elif command.action == "speed":
            self.speed = command.value
        elif command.action == "seek":
            self._anchor = min(max(0.0, command.value), self.duration)

    def state(self, now: float, source: str = "") -> ReplayState:
        position = self.position(now)
        playing = self.playing and position < self.duration
        return ReplayState(playing, self.speed, position, self.duration, source)


class ReplayWatch:
    """Which robots are replays, from the `ReplayState` heard recently (the station's replay bar).

    A robot counts as a replay while its state is at most ``freshness`` [s] old; ``now`` is the
    caller's monotonic clock.
    """

    def __init__(self, freshness: float = 2.0) -> None:
        self.freshness = freshness
        self._states: dict[str, tuple[float, ReplayState]] = {}

    def update(self, states: dict[str, ReplayState], now: float) -> None:
        for robot_id, state in states.items():
            self._states[robot_id] = (now, state)

    def state(self, robot_id: str | None, now: float) -> ReplayState | None:
        """The robot's replay state, or None if it is not (or no longer) a replay."""
        if robot_id is None or robot_id not in self._states:
            return None
        heard, state = self._states[robot_id]
        return state if now - heard <= self.freshness else None
