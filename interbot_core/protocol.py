"""Tablet <-> Base Station message protocol: JSON objects over TCP (thesis §5.3.1-5.3.2).

The thesis (Listings 5.1 and 5.2) defines seven Tablet -> Base Station messages (``speed``,
``goal``, ``pause``, ``stop``, ``tour``, ``home``, ``requestFrom``) and three Base Station ->
Tablet messages (``initial_pose``, ``pose``, ``goal``), each one JSON object with exactly one
top-level key. This module keeps those keys verbatim (the OCR of the thesis shows "initial pose"
and "x pos"; the real keys have underscores) and adds, with snake_case keys, the messages the
thesis describes in prose but does not list: the version handshake, latency ping/pong, guided
tour control and state, "Help me!" initial pose by room, malfunction reports, requests shown at
a room and their answer, cancellation, permissions, localisation state, status text and errors.

Every message is a frozen dataclass with ``to_json()`` (the whole ``{key: body}`` object) and a
``from_json(body, limits)`` class method that validates the body against `ProtocolLimits`.
`decode_tablet_message` and `decode_station_message` pick the class by the top-level key, one
per direction because ``goal`` means different things each way. `encode` produces one compact
JSON object followed by ``\\n``. `JsonStreamDecoder` splits a TCP byte stream into JSON objects
with an incremental brace-depth scanner, because the thesis's Qt client writes bare objects back
to back (``QJsonDocument::toJson``, indented, no delimiter). See docs/protocol.md.

Nothing here does I/O or reads a clock; ping times are passed in by the caller.
"""

from __future__ import annotations

import json
import logging
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Final, Self

logger = logging.getLogger(__name__)

PROTOCOL_VERSION: Final = 1
"""Version announced in ``hello`` / ``welcome``."""

DEFAULT_MAX_FRAME_BYTES: Final = 65536
"""Largest accepted JSON object on the wire [bytes], separators excluded."""

MAX_ID: Final = 2**31 - 1
"""Largest node/room/request id (fits a Qt ``int``)."""

MAX_SEQ: Final = 2**53
"""Largest ping sequence number (exact in a JSON double, as Qt's QJsonValue stores it)."""

MAX_LIST_LENGTH: Final = 1024
"""Most elements in a list field (``tour_state.stops`` / ``visited``)."""


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------


class ProtocolError(Exception):
    """A frame or message that breaks the protocol. ``code`` is sent back in ``error.code``."""

    code: ClassVar[str] = "protocol_error"

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field

    def __eq__(self, other: object) -> bool:
        return (
            type(other) is type(self)
            and isinstance(other, ProtocolError)
            and (other.message, other.field) == (self.message, self.field)
        )

    def __hash__(self) -> int:
        return hash((type(self), self.message, self.field))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.message!r})"


class InvalidJson(ProtocolError):
    """The bytes of a frame are not valid UTF-8 JSON (or contain NaN, Infinity, duplicate keys)."""

    code = "invalid_json"


class NotAnObject(InvalidJson):
    """The top-level JSON value is not an object (an array, string, number, true/false/null)."""

    code = "not_an_object"


class FrameTooLarge(ProtocolError):
    """One JSON object is longer than the frame limit."""

    code = "frame_too_large"


class NotOneMessage(ProtocolError):
    """The top-level object has zero or several keys; a frame carries exactly one message."""

    code = "not_one_message"


class UnknownMessage(ProtocolError):
    """The top-level key is not a message of this direction."""

    code = "unknown_message"


class InvalidField(ProtocolError):
    """A field has the wrong type (a bool where a number is expected, NaN, a bad enum value)."""

    code = "invalid_field"


class MissingField(InvalidField):
    """A required field is absent."""

    code = "missing_field"


class UnknownField(InvalidField):
    """A field that the message does not define."""

    code = "unknown_field"


class OutOfRange(InvalidField):
    """A number outside its limits, a goal that is not a node id, or a string too long."""

    code = "out_of_range"


# --------------------------------------------------------------------------------------------
# Limits and field validation
# --------------------------------------------------------------------------------------------


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


@dataclass(frozen=True)
class ProtocolLimits:
    """Bounds applied when decoding messages.

    ``node_ids`` is the set of topological node ids accepted as goals and rooms, or None to
    accept any id in ``0..MAX_ID``. Speeds outside ``±max_linear`` / ``±max_angular`` are
    rejected, not clamped: the sender is told, rather than the robot moving at a speed nobody
    asked for.
    """

    max_linear: float = 1.0  # [m/s]
    max_angular: float = 2.0  # [rad/s]
    node_ids: frozenset[int] | None = None
    max_string_length: int = 500  # [characters]

    def __post_init__(self) -> None:
        for name in ("max_linear", "max_angular"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"ProtocolLimits.{name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"ProtocolLimits.{name} must be finite and > 0, got {value!r}")
        if self.node_ids is not None:
            if not isinstance(self.node_ids, frozenset):
                raise ValueError("ProtocolLimits.node_ids must be a frozenset of ints or None")
            bad = [n for n in self.node_ids if not _is_int(n) or not 0 <= n <= MAX_ID]
            if bad:
                raise ValueError(
                    f"ProtocolLimits.node_ids must be ints in 0..{MAX_ID}, got {sorted(bad)!r}"
                )
        if not _is_int(self.max_string_length) or self.max_string_length < 1:
            raise ValueError(
                f"ProtocolLimits.max_string_length must be an int >= 1, "
                f"got {self.max_string_length!r}"
            )


DEFAULT_LIMITS: Final = ProtocolLimits()


def _describe(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _type_name(value: object) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list | tuple):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _object(body: object, path: str, keys: tuple[str, ...]) -> Mapping[str, object]:
    """Check that ``body`` is an object with exactly ``keys``."""
    if not isinstance(body, dict):
        raise InvalidField(
            f"{path} must be an object with keys {', '.join(keys)}; got {_type_name(body)}",
            path,
        )
    missing = [k for k in keys if k not in body]
    if missing:
        raise MissingField(
            f"{path}.{missing[0]} is missing ({path} needs {', '.join(keys)})",
            f"{path}.{missing[0]}",
        )
    extra = sorted(str(k) for k in body if k not in keys)
    if extra:
        raise UnknownField(
            f"{path}.{extra[0]} is not a field of {path} (allowed: {', '.join(keys)})",
            f"{path}.{extra[0]}",
        )
    return body


def _bool(value: object, path: str) -> bool:
    if not isinstance(value, bool):
        raise InvalidField(f"{path} must be true or false, got {_describe(value)}", path)
    return value


def _true(value: object, path: str) -> bool:
    if value is not True:
        raise InvalidField(f"{path} must be true, got {_describe(value)}", path)
    return True


def _float(value: object, path: str, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidField(f"{path} must be a number{unit}, got {_describe(value)}", path)
    number = float(value)
    if not math.isfinite(number):
        raise InvalidField(f"{path} must be a finite number{unit}, got {value!r}", path)
    return number


def _bounded_float(value: object, path: str, bound: float, unit: str) -> float:
    number = _float(value, path, f" [{unit}]")
    if not -bound <= number <= bound:
        raise OutOfRange(
            f"{path} = {number:g} {unit} is outside the allowed range "
            f"[{-bound:g}, {bound:g}] {unit}",
            path,
        )
    return number


def _int(value: object, path: str, low: int, high: int) -> int:
    if not _is_int(value):
        raise InvalidField(
            f"{path} must be an integer in {low}..{high}, got {_describe(value)}", path
        )
    assert isinstance(value, int)
    if not low <= value <= high:
        raise OutOfRange(f"{path} = {value} is outside the allowed range {low}..{high}", path)
    return value


def _node(value: object, path: str, limits: ProtocolLimits) -> int:
    """A topological node id: an int in ``limits.node_ids`` (or 0..MAX_ID when that is None)."""
    node = _int(value, path, 0, MAX_ID)
    if limits.node_ids is not None and node not in limits.node_ids:
        ids = sorted(limits.node_ids)
        if ids and ids == list(range(ids[0], ids[-1] + 1)):
            allowed = f"nodes {ids[0]}..{ids[-1]}"
        else:
            allowed = "nodes " + ", ".join(map(str, ids[:20])) + (", ..." if len(ids) > 20 else "")
        raise OutOfRange(f"{path} = {node} is not a node of the topological map ({allowed})", path)
    return node


def _optional_node(value: object, path: str, limits: ProtocolLimits) -> int | None:
    return None if value is None else _node(value, path, limits)


def _nodes(value: object, path: str, limits: ProtocolLimits) -> tuple[int, ...]:
    if not isinstance(value, list | tuple):
        raise InvalidField(f"{path} must be an array of node ids, got {_describe(value)}", path)
    if len(value) > MAX_LIST_LENGTH:
        raise OutOfRange(
            f"{path} has {len(value)} elements; at most {MAX_LIST_LENGTH} are allowed", path
        )
    return tuple(_node(v, f"{path}[{i}]", limits) for i, v in enumerate(value))


def _str(value: object, path: str, limits: ProtocolLimits) -> str:
    if not isinstance(value, str):
        raise InvalidField(f"{path} must be a string, got {_describe(value)}", path)
    _check_encodable(value, path)
    if len(value) > limits.max_string_length:
        raise OutOfRange(
            f"{path} has {len(value)} characters; at most {limits.max_string_length} are allowed",
            path,
        )
    return value


def _choice(value: object, path: str, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in allowed:
        raise InvalidField(
            f"{path} must be one of {', '.join(allowed)}; got {_describe(value)}", path
        )
    return value


def _check_plain(value: object, path: str, kind: type) -> None:
    """Constructor-time check (limit independent) so a bad message cannot even be built."""
    if kind is float:
        _float(value, path)
    elif kind is int:
        if not _is_int(value):
            raise InvalidField(f"{path} must be an integer, got {_describe(value)}", path)
    elif kind is bool:
        _bool(value, path)
    elif kind is str:
        if not isinstance(value, str):
            raise InvalidField(f"{path} must be a string, got {_describe(value)}", path)
        _check_encodable(value, path)


def _check_encodable(value: str, path: str) -> None:
    """Reject lone surrogates (legal in a JSON escape, not encodable as UTF-8)."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise InvalidField(f"{path} contains a lone UTF-16 surrogate", path) from None


# --------------------------------------------------------------------------------------------
# Messages
# --------------------------------------------------------------------------------------------


JsonObject = dict[str, Any]


@dataclass(frozen=True)
class Message:
    """Base of every message: ``KEY`` is its top-level JSON key."""

    KEY: ClassVar[str] = ""

    def to_json(self) -> JsonObject:
        raise NotImplementedError

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        raise NotImplementedError


# ---- Tablet -> Base Station (thesis Listing 5.1) -------------------------------------------


@dataclass(frozen=True)
class Speed(Message):
    """Joystick command: ``{"speed": {"linear": 0.3, "angular": -0.5}}`` [m/s], [rad/s].

    Optional (issue 11; a thesis-era tablet sends neither): ``seq``, a counter that grows with
    each command, and ``t``, the tablet's monotonic clock [s] when it sent the command. The
    station drops a command that arrives out of order or later than its latency ceiling.
    """

    KEY: ClassVar[str] = "speed"
    linear: float  # [m/s]
    angular: float  # [rad/s]
    seq: int | None = None
    t: float | None = None  # [s] tablet clock

    def __post_init__(self) -> None:
        _check_plain(self.linear, "speed.linear", float)
        _check_plain(self.angular, "speed.angular", float)
        if self.seq is not None:
            _check_plain(self.seq, "speed.seq", int)
        if self.t is not None:
            _check_plain(self.t, "speed.t", float)

    def to_json(self) -> JsonObject:
        body: dict[str, object] = {"linear": float(self.linear), "angular": float(self.angular)}
        if self.seq is not None:
            body["seq"] = self.seq
        if self.t is not None:
            body["t"] = float(self.t)
        return {self.KEY: body}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        keys = (
            "linear",
            "angular",
            *tuple(k for k in ("seq", "t") if isinstance(body, dict) and k in body),
        )
        obj = _object(body, "speed", keys)
        return cls(
            _bounded_float(obj["linear"], "speed.linear", limits.max_linear, "m/s"),
            _bounded_float(obj["angular"], "speed.angular", limits.max_angular, "rad/s"),
            _int(obj["seq"], "speed.seq", 0, MAX_SEQ) if "seq" in obj else None,
            _float(obj["t"], "speed.t", " [s]") if "t" in obj else None,
        )


@dataclass(frozen=True)
class Goal(Message):
    """Go to a topological node: ``{"goal": 7}``."""

    KEY: ClassVar[str] = "goal"
    node: int

    def __post_init__(self) -> None:
        _check_plain(self.node, "goal", int)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.node}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_node(body, "goal", limits))


@dataclass(frozen=True)
class Pause(Message):
    """``{"pause": true}`` pauses autonomous navigation; ``false`` resumes it."""

    KEY: ClassVar[str] = "pause"
    paused: bool

    def __post_init__(self) -> None:
        _check_plain(self.paused, "pause", bool)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.paused}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_bool(body, "pause"))


@dataclass(frozen=True)
class Stop(Message):
    """``{"stop": true}`` cancels the current motion and task (false is a no-op)."""

    KEY: ClassVar[str] = "stop"
    stop: bool

    def __post_init__(self) -> None:
        _check_plain(self.stop, "stop", bool)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.stop}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_bool(body, "stop"))


@dataclass(frozen=True)
class Tour(Message):
    """``{"tour": true}`` starts a guided tour; ``false`` ends it (like tour_control "end")."""

    KEY: ClassVar[str] = "tour"
    start: bool

    def __post_init__(self) -> None:
        _check_plain(self.start, "tour", bool)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.start}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_bool(body, "tour"))


@dataclass(frozen=True)
class Home(Message):
    """``{"home": true}``: go back to the home node. The value must be ``true``."""

    KEY: ClassVar[str] = "home"

    def to_json(self) -> JsonObject:
        return {self.KEY: True}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        _true(body, "home")
        return cls()


@dataclass(frozen=True)
class RequestFrom(Message):
    """Fetch or deliver: ``{"requestFrom": {"request", "room", "deliverTo", "status"}}``.

    ``request`` is the user's text, ``room`` the node to fetch from, ``deliver_to`` the node to
    bring it to; ``status`` is the thesis's flag for a filled-in request (true).
    """

    KEY: ClassVar[str] = "requestFrom"
    request: str
    room: int
    deliver_to: int
    status: bool

    def __post_init__(self) -> None:
        _check_plain(self.request, "requestFrom.request", str)
        _check_plain(self.room, "requestFrom.room", int)
        _check_plain(self.deliver_to, "requestFrom.deliverTo", int)
        _check_plain(self.status, "requestFrom.status", bool)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {
                "request": self.request,
                "room": self.room,
                "deliverTo": self.deliver_to,
                "status": self.status,
            }
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "requestFrom", ("request", "room", "deliverTo", "status"))
        return cls(
            _str(obj["request"], "requestFrom.request", limits),
            _node(obj["room"], "requestFrom.room", limits),
            _node(obj["deliverTo"], "requestFrom.deliverTo", limits),
            _bool(obj["status"], "requestFrom.status"),
        )


# ---- Tablet -> Base Station (added) ---------------------------------------------------------


@dataclass(frozen=True)
class Hello(Message):
    """First message of the tablet: ``{"hello": {"protocol": 1, "client": "tablet"}}``."""

    KEY: ClassVar[str] = "hello"
    protocol: int
    client: str

    def __post_init__(self) -> None:
        _check_plain(self.protocol, "hello.protocol", int)
        _check_plain(self.client, "hello.client", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"protocol": self.protocol, "client": self.client}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "hello", ("protocol", "client"))
        return cls(
            _int(obj["protocol"], "hello.protocol", 1, MAX_ID),
            _str(obj["client"], "hello.client", limits),
        )


TOUR_ACTIONS: Final = ("resume", "end")


@dataclass(frozen=True)
class TourControl(Message):
    """At a tour stop: ``{"tour_control": "resume"}`` or ``{"tour_control": "end"}``."""

    KEY: ClassVar[str] = "tour_control"
    action: str

    def __post_init__(self) -> None:
        _choice(self.action, "tour_control", TOUR_ACTIONS)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.action}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_choice(body, "tour_control", TOUR_ACTIONS))


@dataclass(frozen=True)
class InitialPoseRoom(Message):
    """ "Help me!": the robot stands at this room's node: ``{"initial_pose_room": 4}``."""

    KEY: ClassVar[str] = "initial_pose_room"
    room: int

    def __post_init__(self) -> None:
        _check_plain(self.room, "initial_pose_room", int)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.room}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_node(body, "initial_pose_room", limits))


MALFUNCTION_KINDS: Final = ("collision", "wrong_position", "wrong_orientation", "other")


@dataclass(frozen=True)
class Malfunction(Message):
    """User report: ``{"malfunction": {"kind": "collision", "text": "hit a chair"}}``."""

    KEY: ClassVar[str] = "malfunction"
    kind: str
    text: str

    def __post_init__(self) -> None:
        _choice(self.kind, "malfunction.kind", MALFUNCTION_KINDS)
        _check_plain(self.text, "malfunction.text", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"kind": self.kind, "text": self.text}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "malfunction", ("kind", "text"))
        return cls(
            _choice(obj["kind"], "malfunction.kind", MALFUNCTION_KINDS),
            _str(obj["text"], "malfunction.text", limits),
        )


@dataclass(frozen=True)
class RequestAnswer(Message):
    """Answer to `ShowRequest`: ``{"request_answer": {"id": 3, "accepted": true}}``."""

    KEY: ClassVar[str] = "request_answer"
    id: int
    accepted: bool

    def __post_init__(self) -> None:
        _check_plain(self.id, "request_answer.id", int)
        _check_plain(self.accepted, "request_answer.accepted", bool)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"id": self.id, "accepted": self.accepted}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "request_answer", ("id", "accepted"))
        return cls(
            _int(obj["id"], "request_answer.id", 0, MAX_ID),
            _bool(obj["accepted"], "request_answer.accepted"),
        )


# ---- Both directions --------------------------------------------------------------------------


@dataclass(frozen=True)
class Ping(Message):
    """Latency probe: ``{"ping": {"seq": 12, "t": 3.25}}``; ``t`` is the sender's clock [s]."""

    KEY: ClassVar[str] = "ping"
    seq: int
    t: float  # [s]

    def __post_init__(self) -> None:
        _check_plain(self.seq, f"{self.KEY}.seq", int)
        _check_plain(self.t, f"{self.KEY}.t", float)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"seq": self.seq, "t": float(self.t)}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, cls.KEY, ("seq", "t"))
        return cls(
            _int(obj["seq"], f"{cls.KEY}.seq", 0, MAX_SEQ),
            _float(obj["t"], f"{cls.KEY}.t", " [s]"),
        )

    def pong(self) -> Pong:
        """The answer: the same ``seq`` and ``t``, so the sender computes ``now - t``."""
        return Pong(self.seq, self.t)


@dataclass(frozen=True)
class Pong(Ping):
    """Answer to `Ping`, echoing its fields: ``{"pong": {"seq": 12, "t": 3.25}}``."""

    KEY: ClassVar[str] = "pong"

    def round_trip(self, now: float) -> float:
        """Round-trip time [s] given the sender's clock ``now`` [s]."""
        return now - self.t


@dataclass(frozen=True)
class ErrorReport(Message):
    """Rejection of a received frame: ``{"error": {"code": "out_of_range", "message": "..."}}``."""

    KEY: ClassVar[str] = "error"
    code: str
    message: str

    def __post_init__(self) -> None:
        _check_plain(self.code, "error.code", str)
        _check_plain(self.message, "error.message", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"code": self.code, "message": self.message}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "error", ("code", "message"))
        return cls(
            _str(obj["code"], "error.code", limits),
            _str(obj["message"], "error.message", limits),
        )

    @classmethod
    def from_exception(
        cls, error: ProtocolError, limits: ProtocolLimits = DEFAULT_LIMITS
    ) -> ErrorReport:
        """The report to send back for ``error``, its message cut to the string limit."""
        text = error.message
        if len(text) > limits.max_string_length:
            text = text[: limits.max_string_length - 3] + "..."
        return ErrorReport(error.code, text)


# ---- Base Station -> Tablet (thesis Listing 5.2) ---------------------------------------------


@dataclass(frozen=True)
class InitialPose(Message):
    """``{"initial_pose": false}`` while the robot has no initial pose (thesis §5.3.6)."""

    KEY: ClassVar[str] = "initial_pose"
    is_set: bool

    def __post_init__(self) -> None:
        _check_plain(self.is_set, "initial_pose", bool)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.is_set}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_bool(body, "initial_pose"))


@dataclass(frozen=True)
class Pose(Message):
    """Robot pose in ``map``: ``{"pose": {"x_pos": 1.5, "y_pos": -2.0, "angle": 0.78}}``."""

    KEY: ClassVar[str] = "pose"
    x: float  # [m]
    y: float  # [m]
    angle: float  # [rad], yaw counter-clockwise from map x

    def __post_init__(self) -> None:
        _check_plain(self.x, "pose.x_pos", float)
        _check_plain(self.y, "pose.y_pos", float)
        _check_plain(self.angle, "pose.angle", float)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {"x_pos": float(self.x), "y_pos": float(self.y), "angle": float(self.angle)}
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "pose", ("x_pos", "y_pos", "angle"))
        return cls(
            _float(obj["x_pos"], "pose.x_pos", " [m]"),
            _float(obj["y_pos"], "pose.y_pos", " [m]"),
            _float(obj["angle"], "pose.angle", " [rad]"),
        )


@dataclass(frozen=True)
class GoalStatus(Message):
    """Current goal: ``{"goal": {"goal": 7, "reached": false, "tourReached": false}}``."""

    KEY: ClassVar[str] = "goal"
    goal: int
    reached: bool
    tour_reached: bool

    def __post_init__(self) -> None:
        _check_plain(self.goal, "goal.goal", int)
        _check_plain(self.reached, "goal.reached", bool)
        _check_plain(self.tour_reached, "goal.tourReached", bool)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {
                "goal": self.goal,
                "reached": self.reached,
                "tourReached": self.tour_reached,
            }
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "goal", ("goal", "reached", "tourReached"))
        return cls(
            _node(obj["goal"], "goal.goal", limits),
            _bool(obj["reached"], "goal.reached"),
            _bool(obj["tourReached"], "goal.tourReached"),
        )


# ---- Base Station -> Tablet (added) -----------------------------------------------------------


@dataclass(frozen=True)
class Welcome(Message):
    """Accepts a `Hello`: ``{"welcome": {"protocol": 1, "robot": "interbot1"}}``."""

    KEY: ClassVar[str] = "welcome"
    protocol: int
    robot: str

    def __post_init__(self) -> None:
        _check_plain(self.protocol, "welcome.protocol", int)
        _check_plain(self.robot, "welcome.robot", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"protocol": self.protocol, "robot": self.robot}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "welcome", ("protocol", "robot"))
        return cls(
            _int(obj["protocol"], "welcome.protocol", 1, MAX_ID),
            _str(obj["robot"], "welcome.robot", limits),
        )


@dataclass(frozen=True)
class Refused(Message):
    """Connection refused, then closed: ``{"refused": {"reason": "a tablet is connected"}}``."""

    KEY: ClassVar[str] = "refused"
    reason: str

    def __post_init__(self) -> None:
        _check_plain(self.reason, "refused.reason", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"reason": self.reason}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "refused", ("reason",))
        return cls(_str(obj["reason"], "refused.reason", limits))


@dataclass(frozen=True)
class TourState(Message):
    """Guided tour progress: ``{"tour_state": {"stops": [...], "visited": [...], "next": 5}}``.

    ``stops`` are the tour's nodes in order, ``visited`` those already reached, ``next`` the
    current target or null when the tour is over.
    """

    KEY: ClassVar[str] = "tour_state"
    stops: tuple[int, ...]
    visited: tuple[int, ...]
    next: int | None

    def __post_init__(self) -> None:
        for name in ("stops", "visited"):
            value = getattr(self, name)
            if not isinstance(value, tuple) or not all(_is_int(v) for v in value):
                raise InvalidField(
                    f"tour_state.{name} must be a tuple of ints, got {_describe(value)}",
                    f"tour_state.{name}",
                )
        if self.next is not None:
            _check_plain(self.next, "tour_state.next", int)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {"stops": list(self.stops), "visited": list(self.visited), "next": self.next}
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "tour_state", ("stops", "visited", "next"))
        return cls(
            _nodes(obj["stops"], "tour_state.stops", limits),
            _nodes(obj["visited"], "tour_state.visited", limits),
            _optional_node(obj["next"], "tour_state.next", limits),
        )


@dataclass(frozen=True)
class ShowRequest(Message):
    """Show a request to the people at ``room``; answered by `RequestAnswer` with ``id``.

    ``{"show_request": {"id": 3, "request": "the blue folder", "room": 4, "deliver_to": 9}}``.
    """

    KEY: ClassVar[str] = "show_request"
    id: int
    request: str
    room: int
    deliver_to: int

    def __post_init__(self) -> None:
        _check_plain(self.id, "show_request.id", int)
        _check_plain(self.request, "show_request.request", str)
        _check_plain(self.room, "show_request.room", int)
        _check_plain(self.deliver_to, "show_request.deliver_to", int)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {
                "id": self.id,
                "request": self.request,
                "room": self.room,
                "deliver_to": self.deliver_to,
            }
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "show_request", ("id", "request", "room", "deliver_to"))
        return cls(
            _int(obj["id"], "show_request.id", 0, MAX_ID),
            _str(obj["request"], "show_request.request", limits),
            _node(obj["room"], "show_request.room", limits),
            _node(obj["deliver_to"], "show_request.deliver_to", limits),
        )


@dataclass(frozen=True)
class Cancel(Message):
    """The station cancelled the tablet's task: ``{"cancel": {"reason": "by the operator"}}``."""

    KEY: ClassVar[str] = "cancel"
    reason: str

    def __post_init__(self) -> None:
        _check_plain(self.reason, "cancel.reason", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"reason": self.reason}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "cancel", ("reason",))
        return cls(_str(obj["reason"], "cancel.reason", limits))


@dataclass(frozen=True)
class Permissions(Message):
    """What the tablet may do (thesis §5.3 "Tablet Control").

    ``{"permissions": {"teleop": true, "goals": true, "tours": true, "requests": false}}``.
    """

    KEY: ClassVar[str] = "permissions"
    teleop: bool
    goals: bool
    tours: bool
    requests: bool

    def __post_init__(self) -> None:
        for name in ("teleop", "goals", "tours", "requests"):
            _check_plain(getattr(self, name), f"permissions.{name}", bool)

    def to_json(self) -> JsonObject:
        return {
            self.KEY: {
                "teleop": self.teleop,
                "goals": self.goals,
                "tours": self.tours,
                "requests": self.requests,
            }
        }

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        names = ("teleop", "goals", "tours", "requests")
        obj = _object(body, "permissions", names)
        t, g, o, r = (_bool(obj[n], f"permissions.{n}") for n in names)
        return cls(t, g, o, r)


LOCALISATION_STATES: Final = ("unset", "ok", "degraded", "lost", "searching")


@dataclass(frozen=True)
class Localisation(Message):
    """``{"localisation": "lost"}``: the tablet then offers "Help me!" (thesis §5.2.2.1)."""

    KEY: ClassVar[str] = "localisation"
    state: str

    def __post_init__(self) -> None:
        _choice(self.state, "localisation", LOCALISATION_STATES)

    def to_json(self) -> JsonObject:
        return {self.KEY: self.state}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        return cls(_choice(body, "localisation", LOCALISATION_STATES))


@dataclass(frozen=True)
class StatusInfo(Message):
    """Task and status text: ``{"status": {"task": "goal 7", "message": "on the way"}}``."""

    KEY: ClassVar[str] = "status"
    task: str
    message: str

    def __post_init__(self) -> None:
        _check_plain(self.task, "status.task", str)
        _check_plain(self.message, "status.message", str)

    def to_json(self) -> JsonObject:
        return {self.KEY: {"task": self.task, "message": self.message}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "status", ("task", "message"))
        return cls(
            _str(obj["task"], "status.task", limits), _str(obj["message"], "status.message", limits)
        )


SAFETY_ZONES: Final = ("none", "slowdown", "limit", "approach", "stop", "no_data")
MAX_SAFETY_DISTANCE: Final = 1000.0  # [m] "nothing near"


@dataclass(frozen=True)
class SafetyInfo(Message):
    """The robot's collision monitor for the person at the joystick (issue 17):
    ``{"safety": {"zone": "stop", "distance": 0.04, "assisted": true}}`` — the most restrictive
    active zone, the distance [m] from the robot's outline to the nearest laser return
    (1000 = nothing near) and whether the robot assists the tablet's driving."""

    KEY: ClassVar[str] = "safety"
    zone: str
    distance: float
    assisted: bool

    def __post_init__(self) -> None:
        _choice(self.zone, "safety.zone", SAFETY_ZONES)
        distance = _float(self.distance, "safety.distance", " [m]")
        if not 0.0 <= distance <= MAX_SAFETY_DISTANCE:
            raise OutOfRange(
                f"safety.distance = {distance:g} m is outside [0, {MAX_SAFETY_DISTANCE:g}] m",
                "safety.distance",
            )
        _bool(self.assisted, "safety.assisted")

    def to_json(self) -> JsonObject:
        return {self.KEY: {"zone": self.zone, "distance": self.distance, "assisted": self.assisted}}

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        obj = _object(body, "safety", ("zone", "distance", "assisted"))
        return cls(
            _choice(obj["zone"], "safety.zone", SAFETY_ZONES),
            _float(obj["distance"], "safety.distance", " [m]"),
            _bool(obj["assisted"], "safety.assisted"),
        )


# --------------------------------------------------------------------------------------------
# Decoding and encoding
# --------------------------------------------------------------------------------------------

TabletMessage = (
    Speed
    | Goal
    | Pause
    | Stop
    | Tour
    | Home
    | RequestFrom
    | Hello
    | TourControl
    | InitialPoseRoom
    | Malfunction
    | RequestAnswer
    | Ping
    | Pong
    | ErrorReport
)
"""Messages the Base Station accepts from the Tablet."""

StationMessage = (
    InitialPose
    | Pose
    | GoalStatus
    | Welcome
    | Refused
    | TourState
    | ShowRequest
    | Cancel
    | Permissions
    | Localisation
    | StatusInfo
    | SafetyInfo
    | Ping
    | Pong
    | ErrorReport
)
"""Messages the Tablet accepts from the Base Station."""

TABLET_MESSAGES: Final[Mapping[str, Callable[[object, ProtocolLimits], TabletMessage]]] = {
    Speed.KEY: Speed.from_json,
    Goal.KEY: Goal.from_json,
    Pause.KEY: Pause.from_json,
    Stop.KEY: Stop.from_json,
    Tour.KEY: Tour.from_json,
    Home.KEY: Home.from_json,
    RequestFrom.KEY: RequestFrom.from_json,
    Hello.KEY: Hello.from_json,
    TourControl.KEY: TourControl.from_json,
    InitialPoseRoom.KEY: InitialPoseRoom.from_json,
    Malfunction.KEY: Malfunction.from_json,
    RequestAnswer.KEY: RequestAnswer.from_json,
    Ping.KEY: Ping.from_json,
    Pong.KEY: Pong.from_json,
    ErrorReport.KEY: ErrorReport.from_json,
}

STATION_MESSAGES: Final[Mapping[str, Callable[[object, ProtocolLimits], StationMessage]]] = {
    InitialPose.KEY: InitialPose.from_json,
    Pose.KEY: Pose.from_json,
    GoalStatus.KEY: GoalStatus.from_json,
    Welcome.KEY: Welcome.from_json,
    Refused.KEY: Refused.from_json,
    TourState.KEY: TourState.from_json,
    ShowRequest.KEY: ShowRequest.from_json,
    Cancel.KEY: Cancel.from_json,
    Permissions.KEY: Permissions.from_json,
    Localisation.KEY: Localisation.from_json,
    StatusInfo.KEY: StatusInfo.from_json,
    SafetyInfo.KEY: SafetyInfo.from_json,
    Ping.KEY: Ping.from_json,
    Pong.KEY: Pong.from_json,
    ErrorReport.KEY: ErrorReport.from_json,
}


def _single_key(obj: object) -> tuple[str, object]:
    if not isinstance(obj, dict):
        raise NotAnObject(f"a message must be a JSON object, got {_type_name(obj)}")
    if len(obj) != 1:
        keys = ", ".join(sorted(map(str, obj))) or "none"
        raise NotOneMessage(
            f"a message must be an object with exactly one key, got {len(obj)} ({keys})"
        )
    ((key, body),) = obj.items()
    return str(key), body


def decode_tablet_message(obj: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> TabletMessage:
    """Validate one decoded JSON object received by the Base Station from the Tablet."""
    key, body = _single_key(obj)
    parser = TABLET_MESSAGES.get(key)
    if parser is None:
        where = " (it is a Base Station -> Tablet message)" if key in STATION_MESSAGES else ""
        raise UnknownMessage(
            f"unknown tablet message {_describe(key)}{where}; "
            f"known: {', '.join(sorted(TABLET_MESSAGES))}",
            key,
        )
    return parser(body, limits)


def decode_station_message(obj: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> StationMessage:
    """Validate one decoded JSON object received by the Tablet from the Base Station."""
    key, body = _single_key(obj)
    parser = STATION_MESSAGES.get(key)
    if parser is None:
        where = " (it is a Tablet -> Base Station message)" if key in TABLET_MESSAGES else ""
        raise UnknownMessage(
            f"unknown station message {_describe(key)}{where}; "
            f"known: {', '.join(sorted(STATION_MESSAGES))}",
            key,
        )
    return parser(body, limits)


def encode(msg: Message, max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES) -> bytes:
    """One frame: compact UTF-8 JSON of ``msg.to_json()`` followed by ``b"\\n"``.

    Write the result with a single socket write (see FIELD_NOTES: Nagle + delayed ACK).
    Raises FrameTooLarge if the object would exceed ``max_frame_bytes``.
    """
    data = json.dumps(
        msg.to_json(), separators=(",", ":"), ensure_ascii=False, allow_nan=False
    ).encode("utf-8")
    if len(data) > max_frame_bytes:
        raise FrameTooLarge(
            f"{msg.KEY} message is {len(data)} bytes; frames are limited to {max_frame_bytes}",
            msg.KEY,
        )
    return data + b"\n"


# --------------------------------------------------------------------------------------------
# Stream framing
# --------------------------------------------------------------------------------------------


def _reject_constant(name: str) -> object:
    raise ValueError(f"{name} is not valid JSON")


def _pairs_without_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj: dict[str, Any] = {}
    for key, value in pairs:
        if key in obj:
            raise ValueError(f"duplicate key {key!r}")
        obj[key] = value
    return obj


def parse_frame(frame: bytes) -> dict[str, Any]:
    """Parse one complete frame; raises InvalidJson or NotAnObject."""
    try:
        value = json.loads(
            frame.decode("utf-8"),
            parse_constant=_reject_constant,
            object_pairs_hook=_pairs_without_duplicates,
        )
    except UnicodeDecodeError as exc:
        raise InvalidJson(f"frame is not valid UTF-8 ({exc.reason} at byte {exc.start})") from None
    except RecursionError:
        raise InvalidJson("frame is nested too deeply") from None
    except ValueError as exc:
        raise InvalidJson(f"frame is not valid JSON: {exc}") from None
    if not isinstance(value, dict):
        raise NotAnObject(f"top-level JSON value must be an object, got {_type_name(value)}")
    return value


_SEEK, _FRAME, _DISCARD, _JUNK = range(4)
_NON_WS = re.compile(rb"[^ \t\r\n]")
_STRUCTURE = re.compile(rb'[{}\[\]"]')
_IN_STRING = re.compile(rb'["\\]')
_JUNK_STOP = re.compile(rb'[{\["]')
_VALUE_START = frozenset(b'"-0123456789tfn')
_OPEN = frozenset(b"{[")
_QUOTE, _BACKSLASH = ord('"'), ord("\\")


@dataclass
class JsonStreamDecoder:
    """Split a TCP byte stream into JSON objects (one per frame).

    Frames are JSON values that start with ``{`` (or ``[``, reported as NotAnObject) and end at
    the matching bracket, found by a depth counter that skips over strings and their escapes.
    Anything between frames other than whitespace is reported once per run as InvalidJson (or
    NotAnObject for a bare string/number/literal) and skipped up to the next ``{`` or ``[``
    outside a string (a ``"`` in such a run opens a string that is skipped whole, so a bare
    ``"{...}"`` is not mistaken for a frame; an unclosed one is given up after
    ``max_frame_bytes``).
    A frame longer than ``max_frame_bytes`` is reported as FrameTooLarge and discarded up to
    its closing bracket, without buffering it. Scanning is incremental: each byte is looked at
    once, however the stream is split, and a split inside a UTF-8 sequence is harmless because
    multibyte sequences contain no ASCII bytes.

    ``feed`` never raises; it returns the decoded objects and ProtocolError instances in stream
    order. At most ``max_frame_bytes`` bytes are held between calls.
    """

    max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES
    _buf: bytearray = field(default_factory=bytearray, init=False, repr=False)
    _mode: int = field(default=_SEEK, init=False, repr=False)
    _depth: int = field(default=0, init=False, repr=False)
    _in_string: bool = field(default=False, init=False, repr=False)
    _escape: bool = field(default=False, init=False, repr=False)
    _skipped: int = field(default=0, init=False, repr=False)

    def __post_init__(self) -> None:
        if not _is_int(self.max_frame_bytes) or self.max_frame_bytes < 2:
            raise ValueError(f"max_frame_bytes must be an int >= 2, got {self.max_frame_bytes!r}")

    @property
    def buffered_bytes(self) -> int:
        """Bytes of an incomplete frame held for the next feed (always <= max_frame_bytes)."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget any partial frame (call on reconnect)."""
        self._buf.clear()
        self._mode = _SEEK
        self._depth = 0
        self._in_string = self._escape = False
        self._skipped = 0

    def feed(self, data: bytes) -> list[dict[str, Any] | ProtocolError]:
        """Scan ``data`` and return every frame completed by it, in order."""
        out: list[dict[str, Any] | ProtocolError] = []
        try:
            self._scan(bytes(data), out)
        except Exception as exc:  # pragma: no cover - defensive: feed must never raise
            logger.exception("stream decoder failed; resetting")
            self.reset()
            out.append(InvalidJson(f"stream decoder error ({type(exc).__name__}); reset"))
        return out

    # The scanner is a state machine over four modes: _SEEK (between frames), _FRAME (inside a
    # frame, buffering), _DISCARD (inside an oversized frame, not buffering) and _JUNK
    # (skipping a run of non-JSON bytes or a bare top-level string).
    def _scan(self, data: bytes, out: list[dict[str, Any] | ProtocolError]) -> None:
        i, n = 0, len(data)
        while i < n:
            if self._mode == _SEEK:
                m = _NON_WS.search(data, i)
                if m is None:
                    return
                i = m.start()
                byte = data[i]
                if byte in _OPEN:
                    self._mode = _FRAME
                    self._depth = 0
                    self._in_string = self._escape = False
                    self._buf.clear()
                    continue
                self._mode = _JUNK
                self._skipped = 0
                self._in_string = byte == _QUOTE
                self._escape = False
                if byte in _VALUE_START:
                    out.append(NotAnObject("top-level JSON value must be an object"))
                else:
                    out.append(
                        InvalidJson(f"unexpected byte {bytes([byte])!r} between JSON objects")
                    )
                i += 1
            elif self._mode == _JUNK:
                if self._in_string:
                    i = self._skip_string(data, i, n)
                    if self._in_string:
                        self._skipped += n - i
                        if self._skipped > self.max_frame_bytes:
                            self._in_string = False  # give up on the string; plain junk
                        return
                    continue
                m = _JUNK_STOP.search(data, i)
                if m is None:
                    return
                i = m.start()
                if data[i] == _QUOTE:  # a string inside junk: skip it whole, no new error
                    self._in_string = True
                    self._skipped = 0
                    i += 1
                else:
                    self._mode = _SEEK
            else:
                i = self._scan_frame(data, i, n, out)

    def _skip_string(self, data: bytes, i: int, n: int) -> int:
        """Advance through a JSON string body; returns the index after what was consumed."""
        while i < n:
            if self._escape:
                self._escape = False
                i += 1
                continue
            m = _IN_STRING.search(data, i)
            if m is None:
                return n
            i = m.end()
            if data[m.start()] == _BACKSLASH:
                self._escape = True
            else:
                self._in_string = False
                return i
        return i

    def _scan_frame(
        self, data: bytes, i: int, n: int, out: list[dict[str, Any] | ProtocolError]
    ) -> int:
        """Scan inside a frame from ``i``; returns where scanning stopped."""
        start = i
        end = n  # exclusive end of this frame's bytes within data, if the frame completes
        done = False
        while i < n:
            if self._in_string:
                i = self._skip_string(data, i, n)
                continue
            m = _STRUCTURE.search(data, i)
            if m is None:
                i = n
                break
            i = m.end()
            byte = data[m.start()]
            if byte == _QUOTE:
                self._in_string = True
            elif byte in _OPEN:
                self._depth += 1
            else:
                self._depth -= 1
                if self._depth == 0:
                    done, end = True, i
                    break
        chunk_end = end if done else n
        if self._mode == _FRAME:
            if len(self._buf) + (chunk_end - start) > self.max_frame_bytes:
                out.append(
                    FrameTooLarge(
                        f"JSON object longer than {self.max_frame_bytes} bytes; discarded"
                    )
                )
                self._buf.clear()
                self._mode = _DISCARD
            else:
                self._buf += data[start:chunk_end]
        if done:
            if self._mode == _FRAME:
                frame = bytes(self._buf)
                self._buf.clear()
                try:  # a frame that started with "[" always raises NotAnObject here
                    out.append(parse_frame(frame))
                except ProtocolError as exc:
                    out.append(exc)
            self._mode = _SEEK
            self._depth = 0
        return chunk_end
