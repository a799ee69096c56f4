"""Tablet <-> Base Station message protocol: JSON objects over TCP (thesis §5.3.1-5.3.2).

The thesis (Listings 5.1 and 5.2) defines seven Tablet -> Base Station messages (``speed``,
``goal``, ``pause``, ``stop``, ``tour``, ``home``, ``requestFrom``) and three Base Station ->
Tablet messages (``initial_pose``, ``pose``, ``goal``), each one JSON object with exactly one
top-level key. This module keeps those keys verbatim (the OCR of the thesis shows "initial pose"
and "x pos"; the real keys have underscores) and adds, with snake_case keys, the messages the
thesis describes in prose but does not list: the version handshake, latency ping/pong, guided
tour control and state, "Help me!" initial pose by room, malfunction reports, requests shown at
a room and their answer, cancellation, permissions, localisation state, status text and errors.

Every message is a frozen msgspec Struct whose field types declare its rules (types, ranges,
choices; `interbot_core.schema`, issue 13), with ``to_json()`` (the whole ``{key: body}``
object) and ``from_json(body, limits)``, which also applies the connection's `ProtocolLimits`.
`decode_tablet_message` and `decode_station_message` pick the class by the top-level key, one
per direction because ``goal`` means different things each way. `encode` produces one compact
JSON object followed by ``\\n``. `JsonStreamDecoder` splits a TCP byte stream into JSON objects
with an incremental brace-depth scanner, because the thesis's Qt client writes bare objects back
to back (``QJsonDocument::toJson``, indented, no delimiter). See docs/protocol.md.

Nothing here does I/O or reads a clock; ping times are passed in by the caller.
"""

from __future__ import annotations

import enum
import logging
import re
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Annotated, Any, ClassVar, Final, Literal, Self

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import FINITE, SchemaError

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
# Limits
# --------------------------------------------------------------------------------------------


class ProtocolLimits(msgspec.Struct, frozen=True, kw_only=True):
    """Bounds applied when decoding messages, set by the station's configuration.

    ``node_ids`` is the set of topological node ids accepted as goals and rooms, or None to
    accept any id in ``0..MAX_ID``. Speeds outside ``±max_linear`` / ``±max_angular`` are
    rejected, not clamped: the sender is told, rather than the robot moving at a speed nobody
    asked for.
    """

    max_linear: Annotated[float, Meta(gt=0.0, le=FINITE)] = 1.0  # [m/s]
    max_angular: Annotated[float, Meta(gt=0.0, le=FINITE)] = 2.0  # [rad/s]
    node_ids: frozenset[Annotated[int, Meta(ge=0, le=MAX_ID)]] | None = None
    max_string_length: Annotated[int, Meta(ge=1)] = 500  # [characters]

    def __post_init__(self) -> None:
        if self.node_ids is not None and not isinstance(self.node_ids, frozenset):
            raise ValueError("ProtocolLimits.node_ids must be a frozenset of ints or None")
        try:
            schema.check_fields(self, "ProtocolLimits")
        except SchemaError as exc:
            raise ValueError(exc.message) from None


DEFAULT_LIMITS: Final = ProtocolLimits()


class _Bound(enum.Enum):
    """Markers in a field's ``Annotated`` type: the `ProtocolLimits` entry that bounds it."""

    NODE = "node"
    LINEAR = "linear"
    ANGULAR = "angular"
    TEXT = "text"


Node = Annotated[int, Meta(ge=0, le=MAX_ID), _Bound.NODE]
"""A topological node id (checked against ``ProtocolLimits.node_ids`` on decoding)."""
Nodes = Annotated[tuple[Node, ...], Meta(max_length=MAX_LIST_LENGTH)]
Text = Annotated[str, _Bound.TEXT]
"""Free text (at most ``ProtocolLimits.max_string_length`` characters on decoding)."""
Id = Annotated[int, Meta(ge=0, le=MAX_ID)]
Seq = Annotated[int, Meta(ge=0, le=MAX_SEQ)]
Version = Annotated[int, Meta(ge=1, le=MAX_ID)]
Seconds = Annotated[float, Meta(ge=-FINITE, le=FINITE, extra={"unit": "s"})]
Metres = Annotated[float, Meta(ge=-FINITE, le=FINITE, extra={"unit": "m"})]
Radians = Annotated[float, Meta(ge=-FINITE, le=FINITE, extra={"unit": "rad"})]
LinearSpeed = Annotated[float, Meta(ge=-FINITE, le=FINITE, extra={"unit": "m/s"}), _Bound.LINEAR]
AngularSpeed = Annotated[
    float, Meta(ge=-FINITE, le=FINITE, extra={"unit": "rad/s"}), _Bound.ANGULAR
]

_ERRORS: Final[Mapping[str, type[InvalidField]]] = {
    "type": InvalidField,
    "missing": MissingField,
    "unknown": UnknownField,
    "range": OutOfRange,
}


def _protocol_error(error: SchemaError) -> InvalidField:
    return _ERRORS[error.kind](error.message, error.path)


def _bounds(hint: Any) -> tuple[_Bound, ...]:
    """The `_Bound` markers of a field's type, looking inside ``X | None`` and ``tuple[X, ...]``."""
    found = [m for m in getattr(hint, "__metadata__", ()) if isinstance(m, _Bound)]
    for arg in typing.get_args(hint):
        found += _bounds(arg)
    return tuple(found)


@cache
def _bounded_fields(cls: type[Message]) -> tuple[tuple[str, str, _Bound], ...]:
    """``(attribute, path, bound)`` for every field of ``cls`` that `ProtocolLimits` bounds."""
    hints = typing.get_type_hints(cls, include_extras=True)
    out = []
    for f in msgspec.structs.fields(cls):
        path = cls.KEY if cls.BARE else f"{cls.KEY}.{f.encode_name}"
        out += [(f.name, path, bound) for bound in _bounds(hints[f.name])]
    return tuple(out)


def _check_node(node: int, path: str, limits: ProtocolLimits) -> None:
    if limits.node_ids is None or node in limits.node_ids:
        return
    ids = sorted(limits.node_ids)
    if ids and ids == list(range(ids[0], ids[-1] + 1)):
        allowed = f"nodes {ids[0]}..{ids[-1]}"
    else:
        allowed = "nodes " + ", ".join(map(str, ids[:20])) + (", ..." if len(ids) > 20 else "")
    raise OutOfRange(f"{path} = {node} is not a node of the topological map ({allowed})", path)


def _check_bounds(msg: Message, limits: ProtocolLimits) -> None:
    """Apply ``limits`` to a decoded message (its types and fixed ranges are already checked)."""
    for name, path, bound in _bounded_fields(type(msg)):
        value = getattr(msg, name)
        if bound is _Bound.NODE:
            if isinstance(value, tuple):
                for i, node in enumerate(value):
                    _check_node(node, f"{path}[{i}]", limits)
            elif value is not None:
                _check_node(value, path, limits)
        elif bound is _Bound.TEXT:
            try:
                schema.check_text(value, path)
            except SchemaError as exc:
                raise _protocol_error(exc) from None
            if len(value) > limits.max_string_length:
                raise OutOfRange(
                    f"{path} has {len(value)} characters; "
                    f"at most {limits.max_string_length} are allowed",
                    path,
                )
        else:
            limit, unit = (
                (limits.max_linear, "m/s")
                if bound is _Bound.LINEAR
                else (limits.max_angular, "rad/s")
            )
            if value is not None and not -limit <= value <= limit:
                raise OutOfRange(
                    f"{path} = {value:g} {unit} is outside the allowed range "
                    f"[{-limit:g}, {limit:g}] {unit}",
                    path,
                )


# --------------------------------------------------------------------------------------------
# Messages
# --------------------------------------------------------------------------------------------


_ENCODER: Final = msgspec.json.Encoder()


class Message(msgspec.Struct, frozen=True, forbid_unknown_fields=True, omit_defaults=True):
    """Base of every message: ``KEY`` is its top-level JSON key.

    A message is a typed declaration; msgspec checks types and fixed ranges, `_check_bounds`
    the limits of the connection (`ProtocolLimits`). A ``BARE`` message has one field whose
    value is the whole body (``{"goal": 7}``); the others' body is an object of their fields.
    An invalid message cannot be built: the constructor raises InvalidField.
    """

    KEY: ClassVar[str] = ""
    BARE: ClassVar[bool] = False

    def __post_init__(self) -> None:
        if schema.decoding():
            return
        try:
            schema.check_fields(self, self.KEY, bare=self.BARE)
        except SchemaError as exc:
            raise _protocol_error(exc) from None

    def body(self) -> object:
        """The value under ``KEY`` (a struct encodes as its fields, with their wire names)."""
        return getattr(self, self.__struct_fields__[0]) if self.BARE else self

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        """Validate the decoded JSON ``body`` of a ``{KEY: body}`` message against ``limits``."""
        try:
            if cls.BARE:  # {"goal": 7} is checked as {"node": 7}, named as "goal"
                name = cls.__struct_encode_fields__[0]
                msg = schema.convert({name: body}, cls, cls.KEY)
            else:
                msg = schema.convert(body, cls, cls.KEY)
        except SchemaError as exc:
            if cls.BARE:
                inner = f"{cls.KEY}.{name}"
                exc = SchemaError(exc.kind, cls.KEY, exc.message.replace(inner, cls.KEY, 1))
            raise _protocol_error(exc) from None
        _check_bounds(msg, limits)
        return msg


# ---- Tablet -> Base Station (thesis Listing 5.1) -------------------------------------------


class Speed(Message, frozen=True):
    """Joystick command: ``{"speed": {"linear": 0.3, "angular": -0.5}}`` [m/s], [rad/s].

    Optional (issue 11; a thesis-era tablet sends neither): ``seq``, a counter that grows with
    each command, and ``t``, the tablet's monotonic clock [s] when it sent the command. The
    station drops a command that arrives out of order or later than its latency ceiling.
    """

    KEY: ClassVar[str] = "speed"
    linear: LinearSpeed
    angular: AngularSpeed
    seq: Seq | None = None
    t: Seconds | None = None  # tablet clock


class Goal(Message, frozen=True):
    """Go to a topological node: ``{"goal": 7}``."""

    KEY: ClassVar[str] = "goal"
    BARE: ClassVar[bool] = True
    node: Node


class Pause(Message, frozen=True):
    """``{"pause": true}`` pauses autonomous navigation; ``false`` resumes it."""

    KEY: ClassVar[str] = "pause"
    BARE: ClassVar[bool] = True
    paused: bool


class Stop(Message, frozen=True):
    """``{"stop": true}`` cancels the current motion and task (false is a no-op)."""

    KEY: ClassVar[str] = "stop"
    BARE: ClassVar[bool] = True
    stop: bool


class Tour(Message, frozen=True):
    """``{"tour": true}`` starts a guided tour; ``false`` ends it (like tour_control "end")."""

    KEY: ClassVar[str] = "tour"
    BARE: ClassVar[bool] = True
    start: bool


class Home(Message, frozen=True):
    """``{"home": true}``: go back to the home node. The value must be ``true``."""

    KEY: ClassVar[str] = "home"

    def body(self) -> object:
        return True

    @classmethod
    def from_json(cls, body: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> Self:
        if body is not True:
            raise InvalidField(f"home must be true, got {schema.describe(body)}", "home")
        return cls()


class RequestFrom(Message, frozen=True, rename={"deliver_to": "deliverTo"}):
    """Fetch or deliver: ``{"requestFrom": {"request", "room", "deliverTo", "status"}}``.

    ``request`` is the user's text, ``room`` the node to fetch from, ``deliver_to`` the node to
    bring it to; ``status`` is the thesis's flag for a filled-in request (true).
    """

    KEY: ClassVar[str] = "requestFrom"
    request: Text
    room: Node
    deliver_to: Node
    status: bool


# ---- Tablet -> Base Station (added) ---------------------------------------------------------


class Hello(Message, frozen=True):
    """First message of the tablet: ``{"hello": {"protocol": 1, "client": "tablet"}}``."""

    KEY: ClassVar[str] = "hello"
    protocol: Version
    client: Text


class TourControl(Message, frozen=True):
    """At a tour stop: ``{"tour_control": "resume"}`` or ``{"tour_control": "end"}``."""

    KEY: ClassVar[str] = "tour_control"
    BARE: ClassVar[bool] = True
    action: Literal["resume", "end"]


class InitialPoseRoom(Message, frozen=True):
    """ "Help me!": the robot stands at this room's node: ``{"initial_pose_room": 4}``."""

    KEY: ClassVar[str] = "initial_pose_room"
    BARE: ClassVar[bool] = True
    room: Node


MalfunctionKind = Literal["collision", "wrong_position", "wrong_orientation", "other"]
MALFUNCTION_KINDS: Final = typing.get_args(MalfunctionKind)


class Malfunction(Message, frozen=True):
    """User report: ``{"malfunction": {"kind": "collision", "text": "hit a chair"}}``."""

    KEY: ClassVar[str] = "malfunction"
    kind: MalfunctionKind
    text: Text


class RequestAnswer(Message, frozen=True):
    """Answer to `ShowRequest`: ``{"request_answer": {"id": 3, "accepted": true}}``."""

    KEY: ClassVar[str] = "request_answer"
    id: Id
    accepted: bool


# ---- Both directions --------------------------------------------------------------------------


class Ping(Message, frozen=True):
    """Latency probe: ``{"ping": {"seq": 12, "t": 3.25}}``; ``t`` is the sender's clock [s]."""

    KEY: ClassVar[str] = "ping"
    seq: Seq
    t: Seconds

    def pong(self) -> Pong:
        """The answer: the same ``seq`` and ``t``, so the sender computes ``now - t``."""
        return Pong(self.seq, self.t)


class Pong(Ping, frozen=True):
    """Answer to `Ping`, echoing its fields: ``{"pong": {"seq": 12, "t": 3.25}}``."""

    KEY: ClassVar[str] = "pong"

    def round_trip(self, now: float) -> float:
        """Round-trip time [s] given the sender's clock ``now`` [s]."""
        return now - self.t


class ErrorReport(Message, frozen=True):
    """Rejection of a received frame: ``{"error": {"code": "out_of_range", "message": "..."}}``."""

    KEY: ClassVar[str] = "error"
    code: Text
    message: Text

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


class InitialPose(Message, frozen=True):
    """``{"initial_pose": false}`` while the robot has no initial pose (thesis §5.3.6)."""

    KEY: ClassVar[str] = "initial_pose"
    BARE: ClassVar[bool] = True
    is_set: bool


class Pose(Message, frozen=True, rename={"x": "x_pos", "y": "y_pos"}):
    """Robot pose in ``map``: ``{"pose": {"x_pos": 1.5, "y_pos": -2.0, "angle": 0.78}}``."""

    KEY: ClassVar[str] = "pose"
    x: Metres
    y: Metres
    angle: Radians  # yaw counter-clockwise from map x


class GoalStatus(Message, frozen=True, rename={"tour_reached": "tourReached"}):
    """Current goal: ``{"goal": {"goal": 7, "reached": false, "tourReached": false}}``."""

    KEY: ClassVar[str] = "goal"
    goal: Node
    reached: bool
    tour_reached: bool


# ---- Base Station -> Tablet (added) -----------------------------------------------------------


class Welcome(Message, frozen=True):
    """Accepts a `Hello`: ``{"welcome": {"protocol": 1, "robot": "interbot1"}}``."""

    KEY: ClassVar[str] = "welcome"
    protocol: Version
    robot: Text


class RobotName(Message, frozen=True):
    """The robot the tablet now drives: ``{"robot": "interbot2"}`` (issue 14).

    `Welcome` names the robot at connect time; when the operator commands another robot the
    station says its name with this message, so the tablet never shows a stale name.
    """

    KEY: ClassVar[str] = "robot"
    BARE: ClassVar[bool] = True
    name: Text


class Refused(Message, frozen=True):
    """Connection refused, then closed: ``{"refused": {"reason": "a tablet is connected"}}``."""

    KEY: ClassVar[str] = "refused"
    reason: Text


class TourState(Message, frozen=True):
    """Guided tour progress: ``{"tour_state": {"stops": [...], "visited": [...], "next": 5}}``.

    ``stops`` are the tour's nodes in order, ``visited`` those already reached, ``next`` the
    current target or null when the tour is over.
    """

    KEY: ClassVar[str] = "tour_state"
    stops: Nodes
    visited: Nodes
    next: Node | None


class ShowRequest(Message, frozen=True):
    """Show a request to the people at ``room``; answered by `RequestAnswer` with ``id``.

    ``{"show_request": {"id": 3, "request": "the blue folder", "room": 4, "deliver_to": 9}}``.
    """

    KEY: ClassVar[str] = "show_request"
    id: Id
    request: Text
    room: Node
    deliver_to: Node


class Cancel(Message, frozen=True):
    """The station cancelled the tablet's task: ``{"cancel": {"reason": "by the operator"}}``."""

    KEY: ClassVar[str] = "cancel"
    reason: Text


class Permissions(Message, frozen=True):
    """What the tablet may do (thesis §5.3 "Tablet Control").

    ``{"permissions": {"teleop": true, "goals": true, "tours": true, "requests": false}}``.
    """

    KEY: ClassVar[str] = "permissions"
    teleop: bool
    goals: bool
    tours: bool
    requests: bool


LocalisationState = Literal["unset", "ok", "degraded", "lost", "searching", "turning"]


class Localisation(Message, frozen=True):
    """``{"localisation": "lost"}``: the tablet then offers "Help me!" (thesis §5.2.2.1)."""

    KEY: ClassVar[str] = "localisation"
    BARE: ClassVar[bool] = True
    state: LocalisationState


class StatusInfo(Message, frozen=True):
    """Task and status text: ``{"status": {"task": "goal 7", "message": "on the way"}}``."""

    KEY: ClassVar[str] = "status"
    task: Text
    message: Text


SafetyZone = Literal["none", "slowdown", "limit", "approach", "stop", "no_data"]
SAFETY_ZONES: Final = typing.get_args(SafetyZone)
MAX_SAFETY_DISTANCE: Final = 1000.0  # [m] "nothing near"


class SafetyInfo(Message, frozen=True):
    """The robot's collision monitor for the person at the joystick (issue 17):
    ``{"safety": {"zone": "stop", "distance": 0.04, "assisted": true}}`` — the most restrictive
    active zone, the distance [m] from the robot's outline to the nearest laser return
    (1000 = nothing near) and whether the robot assists the tablet's driving."""

    KEY: ClassVar[str] = "safety"
    zone: SafetyZone
    distance: Annotated[float, Meta(ge=0.0, le=MAX_SAFETY_DISTANCE, extra={"unit": "m"})]
    assisted: bool


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
    | RobotName
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

TABLET_MESSAGES: Final[Mapping[str, type[TabletMessage]]] = {
    cls.KEY: cls for cls in typing.get_args(TabletMessage)
}
STATION_MESSAGES: Final[Mapping[str, type[StationMessage]]] = {
    cls.KEY: cls for cls in typing.get_args(StationMessage)
}


def _type_name(value: object) -> str:
    if value is None:
        return "null"
    for kinds, name in (
        (bool, "a boolean"),
        (int | float, "a number"),
        (str, "a string"),
        (list | tuple, "an array"),
        (dict, "an object"),
    ):
        if isinstance(value, kinds):
            return name
    return type(value).__name__


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


def _decode(
    obj: object,
    limits: ProtocolLimits,
    known: Mapping[str, type[Message]],
    other: Mapping[str, type[Message]],
    names: tuple[str, str],
) -> Message:
    key, body = _single_key(obj)
    cls = known.get(key)
    if cls is None:
        where = f" (it is a {names[1]} message)" if key in other else ""
        raise UnknownMessage(
            f"unknown {names[0]} message {schema.describe(key)}{where}; "
            f"known: {', '.join(sorted(known))}",
            key,
        )
    return cls.from_json(body, limits)


def decode_tablet_message(obj: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> TabletMessage:
    """Validate one decoded JSON object received by the Base Station from the Tablet."""
    names = ("tablet", "Base Station -> Tablet")
    return _decode(obj, limits, TABLET_MESSAGES, STATION_MESSAGES, names)  # type: ignore[return-value]


def decode_station_message(obj: object, limits: ProtocolLimits = DEFAULT_LIMITS) -> StationMessage:
    """Validate one decoded JSON object received by the Tablet from the Base Station."""
    names = ("station", "Tablet -> Base Station")
    return _decode(obj, limits, STATION_MESSAGES, TABLET_MESSAGES, names)  # type: ignore[return-value]


def encode(msg: Message, max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES) -> bytes:
    """One frame: compact UTF-8 JSON ``{KEY: body}`` followed by ``b"\\n"``.

    Write the result with a single socket write (see FIELD_NOTES: Nagle + delayed ACK).
    Raises FrameTooLarge if the object would exceed ``max_frame_bytes``.
    """
    data = b'{"%s":%s}' % (msg.KEY.encode(), _ENCODER.encode(msg.body()))
    if len(data) > max_frame_bytes:
        raise FrameTooLarge(
            f"{msg.KEY} message is {len(data)} bytes; frames are limited to {max_frame_bytes}",
            msg.KEY,
        )
    return data + b"\n"


# --------------------------------------------------------------------------------------------
# Frames
# --------------------------------------------------------------------------------------------


def parse_frame(frame: bytes) -> dict[str, Any]:
    """Parse one complete frame; raises InvalidJson (bad UTF-8, NaN, duplicate keys, too deep)
    or NotAnObject (`schema.parse_json`)."""
    try:
        value = schema.parse_json(frame)
    except schema.JsonSyntaxError as exc:
        raise InvalidJson(f"frame is {exc}") from None
    if not isinstance(value, dict):
        raise NotAnObject(f"top-level JSON value must be an object, got {_type_name(value)}")
    return value


# --------------------------------------------------------------------------------------------
# Stream framing
# --------------------------------------------------------------------------------------------


_NON_WS = re.compile(rb"[^ \t\r\n]")
_STRUCTURE = re.compile(rb'[{}\[\]"]')
_IN_STRING = re.compile(rb'["\\]')
_JUNK_STOP = re.compile(rb'[{\["]')
_VALUE_START = frozenset(b'"-0123456789tfn')
_OPEN = frozenset(b"{[")
_QUOTE, _BACKSLASH = ord('"'), ord("\\")


@dataclass
class JsonStreamDecoder:
    """Split a TCP byte stream into JSON objects (one per frame), for thesis-era clients that
    write objects back to back with no delimiter.

    A frame starts with ``{`` (or ``[``, reported as NotAnObject) and ends at the matching
    bracket, found by a depth counter that skips strings and their escapes. Anything else
    between frames is reported once per run (InvalidJson, or NotAnObject for a bare value) and
    skipped up to the next ``{`` or ``[`` outside a string (a string in such a run is skipped
    whole, so a bare ``"{...}"`` is no frame; an unclosed one is given up after
    ``max_frame_bytes``). A frame longer than ``max_frame_bytes`` is reported as FrameTooLarge
    and discarded up to its closing bracket without being buffered. Each byte is looked at once
    however the stream is split (a split inside a UTF-8 sequence is harmless: multibyte
    sequences contain no ASCII bytes). ``feed`` never raises; it returns the objects and
    ProtocolError instances in stream order, holding at most ``max_frame_bytes`` between calls.
    """

    max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES
    _buf: bytearray = field(default_factory=bytearray, init=False, repr=False)
    _depth: int = field(default=0, init=False, repr=False)  # > 0: inside a frame
    _junk: bool = field(default=False, init=False, repr=False)  # skipping a run between frames
    _discard: bool = field(default=False, init=False, repr=False)  # frame too large: not kept
    _in_string: bool = field(default=False, init=False, repr=False)
    _escape: bool = field(default=False, init=False, repr=False)
    _skipped: int = field(default=0, init=False, repr=False)  # bytes of a string in junk

    def __post_init__(self) -> None:
        if type(self.max_frame_bytes) is not int or self.max_frame_bytes < 2:
            raise ValueError(f"max_frame_bytes must be an int >= 2, got {self.max_frame_bytes!r}")

    @property
    def buffered_bytes(self) -> int:
        """Bytes of an incomplete frame held for the next feed (always <= max_frame_bytes)."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget any partial frame (call on reconnect)."""
        self._buf.clear()
        self._depth = self._skipped = 0
        self._junk = self._discard = self._in_string = self._escape = False

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

    def _scan(self, data: bytes, out: list[dict[str, Any] | ProtocolError]) -> None:
        i, n, start = 0, len(data), 0  # start: where this data's part of the frame begins
        while i < n:
            if self._in_string:
                before, i = i, self._skip_string(data, i, n)
                if self._in_string and not self._depth:  # an unclosed string in junk
                    self._skipped += i - before
                    self._in_string = self._skipped <= self.max_frame_bytes
            elif self._depth:  # inside a frame
                m = _STRUCTURE.search(data, i)
                if m is None:
                    break
                i, byte = m.end(), data[m.start()]
                if byte == _QUOTE:
                    self._in_string = True
                elif byte in _OPEN:
                    self._depth += 1
                else:
                    self._depth -= 1
                    if not self._depth and self._keep(data[start:i], out):
                        frame = bytes(self._buf)
                        self._buf.clear()
                        try:  # a frame that started with "[" always raises NotAnObject here
                            out.append(parse_frame(frame))
                        except ProtocolError as exc:
                            out.append(exc)
            elif self._junk:
                m = _JUNK_STOP.search(data, i)
                if m is None:
                    return
                i = m.start()
                if data[i] == _QUOTE:  # a string inside junk: skip it whole, no new error
                    self._in_string, self._skipped, i = True, 0, i + 1
                else:
                    self._junk = False
            else:  # between frames
                m = _NON_WS.search(data, i)
                if m is None:
                    return
                i, byte = m.start(), data[m.start()]
                if byte in _OPEN:
                    self._depth, self._discard, start = 1, False, i
                elif byte in _VALUE_START:
                    out.append(NotAnObject("top-level JSON value must be an object"))
                else:
                    out.append(
                        InvalidJson(f"unexpected byte {bytes([byte])!r} between JSON objects")
                    )
                self._junk = byte not in _OPEN
                self._in_string, self._skipped, i = byte == _QUOTE, 0, i + 1
        if self._depth:
            self._keep(data[start:], out)

    def _keep(self, chunk: bytes, out: list[dict[str, Any] | ProtocolError]) -> bool:
        """Buffer ``chunk`` of the current frame; False once the frame is too large."""
        if self._discard:
            return False
        if len(self._buf) + len(chunk) > self.max_frame_bytes:
            out.append(
                FrameTooLarge(f"JSON object longer than {self.max_frame_bytes} bytes; discarded")
            )
            self._buf.clear()
            self._discard = True
            return False
        self._buf += chunk
        return True

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
