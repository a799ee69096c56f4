"""Tests of the Tablet <-> Base Station protocol (thesis §5.3.2, Listings 5.1 and 5.2)."""

from __future__ import annotations

import itertools
import json
import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.protocol import (
    DEFAULT_MAX_FRAME_BYTES,
    PROTOCOL_VERSION,
    STATION_MESSAGES,
    TABLET_MESSAGES,
    Cancel,
    ErrorReport,
    FrameTooLarge,
    Goal,
    GoalStatus,
    Hello,
    Home,
    InitialPose,
    InitialPoseRoom,
    InvalidField,
    InvalidJson,
    JsonStreamDecoder,
    Localisation,
    Malfunction,
    Message,
    MissingField,
    NotAnObject,
    NotOneMessage,
    OutOfRange,
    Pause,
    Permissions,
    Ping,
    Pong,
    Pose,
    ProtocolError,
    ProtocolLimits,
    Refused,
    RequestAnswer,
    RequestFrom,
    RobotName,
    SafetyInfo,
    ShowRequest,
    Speed,
    StatusInfo,
    Stop,
    Tour,
    TourControl,
    TourState,
    UnknownField,
    UnknownMessage,
    Welcome,
    decode_station_message,
    decode_tablet_message,
    encode,
    parse_frame,
)

LIMITS = ProtocolLimits(
    max_linear=0.6, max_angular=1.0, node_ids=frozenset(range(22)), max_string_length=500
)

TABLET_EXAMPLES: list[Message] = [
    Speed(0.5, -0.25),
    Goal(7),
    Pause(True),
    Pause(False),
    Stop(True),
    Tour(True),
    Home(),
    RequestFrom("the blue folder, please", 4, 9, True),
    Hello(PROTOCOL_VERSION, "tablet"),
    TourControl("resume"),
    TourControl("end"),
    InitialPoseRoom(3),
    Malfunction("collision", "hit a chair"),
    RequestAnswer(12, False),
    Ping(1, 12.5),
    Pong(1, 12.5),
    ErrorReport("out_of_range", "pose.x_pos"),
]

STATION_EXAMPLES: list[Message] = [
    InitialPose(False),
    Pose(1.5, -2.0, 0.785),
    GoalStatus(7, False, True),
    Welcome(1, "interbot1"),
    RobotName("interbot2"),
    Refused("another tablet is connected"),
    TourState((1, 3, 5), (1,), 3),
    TourState((1, 3), (1, 3), None),
    ShowRequest(12, "sign this form", 4, 9),
    Cancel("cancelled by the operator"),
    Permissions(True, True, False, False),
    Localisation("lost"),
    StatusInfo("goal 7", "on the way"),
    SafetyInfo("stop", 0.04, True),
    Ping(2, 0.25),
    Pong(2, 0.25),
    ErrorReport("invalid_json", "frame is not valid JSON"),
]


def as_json(msg: Message) -> object:
    """A message as the JSON object on the wire (`encode`, parsed back)."""
    return json.loads(encode(msg))


def test_every_message_class_has_an_example() -> None:
    assert {type(m).KEY for m in TABLET_EXAMPLES} == set(TABLET_MESSAGES)
    assert {type(m).KEY for m in STATION_EXAMPLES} == set(STATION_MESSAGES)


@pytest.mark.parametrize("msg", TABLET_EXAMPLES, ids=repr)
def test_tablet_message_round_trips(msg: Message) -> None:
    frame = encode(msg)
    assert frame.endswith(b"\n") and frame.count(b"\n") == 1
    assert decode_tablet_message(json.loads(frame), LIMITS) == msg
    assert type(decode_tablet_message(as_json(msg), LIMITS)) is type(msg)


@pytest.mark.parametrize("msg", STATION_EXAMPLES, ids=repr)
def test_station_message_round_trips(msg: Message) -> None:
    frame = encode(msg)
    assert decode_station_message(json.loads(frame), LIMITS) == msg
    assert type(decode_station_message(as_json(msg), LIMITS)) is type(msg)


@pytest.mark.parametrize(
    ("msg", "text"),
    [
        (Speed(0.5, -0.25), b'{"speed":{"linear":0.5,"angular":-0.25}}\n'),
        (Goal(7), b'{"goal":7}\n'),
        (Pause(True), b'{"pause":true}\n'),
        (Stop(True), b'{"stop":true}\n'),
        (Tour(True), b'{"tour":true}\n'),
        (Home(), b'{"home":true}\n'),
        (
            RequestFrom("pen", 4, 9, True),
            b'{"requestFrom":{"request":"pen","room":4,"deliverTo":9,"status":true}}\n',
        ),
        (InitialPose(False), b'{"initial_pose":false}\n'),
        (Pose(1.5, -2.0, 0.5), b'{"pose":{"x_pos":1.5,"y_pos":-2.0,"angle":0.5}}\n'),
        (GoalStatus(7, True, False), b'{"goal":{"goal":7,"reached":true,"tourReached":false}}\n'),
        (Hello(1, "tablet"), b'{"hello":{"protocol":1,"client":"tablet"}}\n'),
        (Welcome(1, "interbot1"), b'{"welcome":{"protocol":1,"robot":"interbot1"}}\n'),
        (RobotName("interbot2"), b'{"robot":"interbot2"}\n'),
        (Ping(3, 1.25), b'{"ping":{"seq":3,"t":1.25}}\n'),
        (ErrorReport("c", "m"), b'{"error":{"code":"c","message":"m"}}\n'),
    ],
)
def test_exact_wire_text(msg: Message, text: bytes) -> None:
    assert encode(msg) == text


def test_speed_ints_from_qt_are_accepted_as_floats() -> None:
    # QJsonDocument writes 0.0 as 0
    msg = decode_tablet_message({"speed": {"linear": 0, "angular": 1}}, LIMITS)
    assert msg == Speed(0.0, 1.0)
    assert isinstance(msg, Speed) and isinstance(msg.linear, float)


def test_non_ascii_text_is_sent_as_utf8() -> None:
    frame = encode(StatusInfo("sala de reuniões", "a caminho 🚀"))
    assert "reuniões".encode() in frame
    assert decode_station_message(json.loads(frame.decode("utf-8")), LIMITS) == StatusInfo(
        "sala de reuniões", "a caminho 🚀"
    )


def test_ping_pong_and_round_trip_time() -> None:
    ping = Ping(5, 10.0)
    pong = ping.pong()
    assert pong == Pong(5, 10.0)
    assert as_json(pong) == {"pong": {"seq": 5, "t": 10.0}}
    assert pong.round_trip(now=10.04) == pytest.approx(0.04)


def test_error_report_from_exception_is_truncated_to_the_limit() -> None:
    limits = ProtocolLimits(max_string_length=20)
    report = ErrorReport.from_exception(OutOfRange("x" * 100), limits)
    assert report.code == "out_of_range"
    assert len(report.message) == 20 and report.message.endswith("...")
    assert decode_station_message(as_json(report), limits) == report


# ---- validation -------------------------------------------------------------------------------

TABLET_REJECTS: list[tuple[object, type[ProtocolError], str]] = [
    ([{"stop": True}], NotAnObject, "object"),
    ({}, NotOneMessage, "exactly one key"),
    ({"stop": True, "pause": True}, NotOneMessage, "exactly one key"),
    ({"fly": True}, UnknownMessage, "fly"),
    ({"pose": {"x_pos": 0.0, "y_pos": 0.0, "angle": 0.0}}, UnknownMessage, "Base Station ->"),
    ({"speed": {"linear": 0.7, "angular": 0.0}}, OutOfRange, "speed.linear = 0.7 m/s"),
    ({"speed": {"linear": 0.0, "angular": -1.5}}, OutOfRange, "[-1, 1] rad/s"),
    ({"speed": {"linear": math.nan, "angular": 0.0}}, InvalidField, "finite"),
    ({"speed": {"linear": math.inf, "angular": 0.0}}, InvalidField, "finite"),
    ({"speed": {"linear": True, "angular": 0.0}}, InvalidField, "speed.linear must be a number"),
    ({"speed": {"linear": "0.1", "angular": 0.0}}, InvalidField, "speed.linear"),
    ({"speed": {"linear": 0.1}}, MissingField, "speed.angular is missing"),
    ({"speed": {"linear": 0.1, "angular": 0.0, "x": 1}}, UnknownField, "speed.x"),
    ({"speed": [0.1, 0.0]}, InvalidField, "speed must be an object"),
    ({"goal": 22}, OutOfRange, "nodes 0..21"),
    ({"goal": -1}, OutOfRange, "goal = -1"),
    ({"goal": 3.0}, InvalidField, "integer"),
    ({"goal": True}, InvalidField, "integer"),
    ({"pause": 1}, InvalidField, "pause must be true or false"),
    ({"stop": "yes"}, InvalidField, "stop"),
    ({"tour": None}, InvalidField, "tour"),
    ({"home": False}, InvalidField, "home must be true"),
    (
        {"requestFrom": {"request": "x" * 501, "room": 1, "deliverTo": 2, "status": True}},
        OutOfRange,
        "at most 500",
    ),
    (
        {"requestFrom": {"request": "x", "room": 1, "deliverTo": 99, "status": True}},
        OutOfRange,
        "requestFrom.deliverTo = 99",
    ),
    (
        {"requestFrom": {"request": "x", "room": 1, "deliver_to": 2, "status": True}},
        MissingField,
        "requestFrom.deliverTo",
    ),
    (
        {"requestFrom": {"request": "\ud800", "room": 1, "deliverTo": 2, "status": True}},
        InvalidField,
        "surrogate",
    ),
    ({"hello": {"protocol": 0, "client": "tablet"}}, OutOfRange, "hello.protocol"),
    ({"tour_control": "pause"}, InvalidField, "resume, end"),
    ({"initial_pose_room": 40}, OutOfRange, "initial_pose_room"),
    ({"malfunction": {"kind": "fire", "text": ""}}, InvalidField, "collision"),
    ({"malfunction": {"kind": "other", "text": 5}}, InvalidField, "malfunction.text"),
    ({"request_answer": {"id": 1, "accepted": "no"}}, InvalidField, "request_answer.accepted"),
    ({"ping": {"seq": -1, "t": 0.0}}, OutOfRange, "ping.seq"),
    ({"ping": {"seq": 1, "t": False}}, InvalidField, "ping.t"),
    ({"pong": {"seq": 1}}, MissingField, "pong.t"),
]


@pytest.mark.parametrize(("obj", "error", "text"), TABLET_REJECTS, ids=repr)
def test_tablet_validation_rejects(obj: object, error: type[ProtocolError], text: str) -> None:
    with pytest.raises(error) as info:
        decode_tablet_message(obj, LIMITS)
    assert type(info.value) is error
    assert text in str(info.value)
    assert info.value.code == error.code


STATION_REJECTS: list[tuple[object, type[ProtocolError], str]] = [
    ({"goal": 3}, InvalidField, "goal must be an object"),
    ({"speed": {"linear": 0.0, "angular": 0.0}}, UnknownMessage, "Tablet -> Base Station"),
    ({"pose": {"x_pos": 1.0, "y_pos": math.nan, "angle": 0.0}}, InvalidField, "pose.y_pos"),
    ({"pose": {"x_pos": 1.0, "y": 1.0, "angle": 0.0}}, MissingField, "pose.y_pos"),
    ({"goal": {"goal": 1, "reached": True, "tourReached": 0}}, InvalidField, "goal.tourReached"),
    ({"initial_pose": "false"}, InvalidField, "initial_pose"),
    ({"tour_state": {"stops": [1, 99], "visited": [], "next": 1}}, OutOfRange, "stops[1]"),
    ({"tour_state": {"stops": 1, "visited": [], "next": 1}}, InvalidField, "tour_state.stops"),
    ({"tour_state": {"stops": [], "visited": [], "next": "a"}}, InvalidField, "next"),
    ({"localisation": "maybe"}, InvalidField, "unset, ok, degraded, lost, searching"),
    ({"permissions": {"teleop": True, "goals": True, "tours": True}}, MissingField, "requests"),
    ({"status": {"task": "t", "message": "m", "level": 1}}, UnknownField, "status.level"),
    ({"welcome": {"protocol": 1.5, "robot": "r"}}, InvalidField, "welcome.protocol"),
    ({"error": {"code": 1, "message": "m"}}, InvalidField, "error.code"),
]


@pytest.mark.parametrize(("obj", "error", "text"), STATION_REJECTS, ids=repr)
def test_station_validation_rejects(obj: object, error: type[ProtocolError], text: str) -> None:
    with pytest.raises(error) as info:
        decode_station_message(obj, LIMITS)
    assert type(info.value) is error
    assert text in str(info.value)


def test_speed_at_the_limit_is_accepted() -> None:
    assert decode_tablet_message({"speed": {"linear": -0.6, "angular": 1.0}}, LIMITS) == Speed(
        -0.6, 1.0
    )


def test_string_at_the_limit_is_accepted() -> None:
    body = {"request": "é" * 500, "room": 1, "deliverTo": 2, "status": False}
    assert decode_tablet_message({"requestFrom": body}, LIMITS) == RequestFrom(
        "é" * 500, 1, 2, False
    )


def test_any_node_id_without_a_node_set() -> None:
    assert decode_tablet_message({"goal": 1000}) == Goal(1000)
    with pytest.raises(OutOfRange):
        decode_tablet_message({"goal": 2**31})


def test_node_set_that_is_not_a_range_is_listed() -> None:
    limits = ProtocolLimits(node_ids=frozenset({2, 5, 9}))
    with pytest.raises(OutOfRange, match="nodes 2, 5, 9"):
        decode_tablet_message({"goal": 3}, limits)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"max_linear": 0.0},
        {"max_angular": math.inf},
        {"max_linear": True},
        {"node_ids": frozenset({-1})},
        {"node_ids": {1, 2}},
        {"max_string_length": 0},
    ],
    ids=repr,
)
def test_invalid_limits_are_rejected(kwargs: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match="ProtocolLimits"):
        ProtocolLimits(**kwargs)


@pytest.mark.parametrize(
    "build",
    [
        lambda: Speed(math.nan, 0.0),
        lambda: Speed(True, 0.0),
        lambda: Goal(1.0),  # type: ignore[arg-type]
        lambda: Pause(1),  # type: ignore[arg-type]
        lambda: TourControl("pause"),
        lambda: Malfunction("fire", ""),
        lambda: Localisation("fine"),
        lambda: StatusInfo("\udc00", ""),
        lambda: SafetyInfo("danger", 0.1, True),
        lambda: SafetyInfo("stop", -0.1, True),
        lambda: SafetyInfo("stop", math.inf, False),
        lambda: SafetyInfo("stop", 0.1, 1),  # type: ignore[arg-type]
    ],
)
def test_invalid_messages_cannot_be_constructed(build: Any) -> None:
    with pytest.raises(InvalidField):
        build()


def test_constructor_normalises_lists_and_ints() -> None:
    """A list given for a tuple field is stored as a tuple (the message stays hashable) and an
    int for a float field as a float, so equal messages encode alike."""
    state = TourState([1, 3], (), None)  # type: ignore[arg-type]
    assert state.stops == (1, 3) and isinstance(state.stops, tuple) and hash(state)
    speed = Speed(0, 1)
    assert isinstance(speed.linear, float) and encode(speed) == encode(Speed(0.0, 1.0))
    with pytest.raises(InvalidField, match=r"tour_state.stops\[1\]"):
        TourState([1, "a"], (), None)  # type: ignore[list-item]


def test_encode_rejects_a_frame_over_the_limit() -> None:
    with pytest.raises(FrameTooLarge):
        encode(StatusInfo("x" * 100, "y"), max_frame_bytes=64)


# ---- framing ----------------------------------------------------------------------------------


def test_parse_frame_rejects_nan_duplicates_utf8_and_depth() -> None:
    with pytest.raises(InvalidJson, match="NaN"):
        parse_frame(b'{"speed":{"linear":NaN,"angular":0}}')
    with pytest.raises(InvalidJson, match="duplicate"):
        parse_frame(b'{"stop":true,"stop":false}')
    with pytest.raises(InvalidJson, match="UTF-8"):
        parse_frame(b'{"status":"\xff"}')
    with pytest.raises(InvalidJson):
        parse_frame(b'{"a":' + b"[" * 50000 + b"]" * 50000 + b"}")
    with pytest.raises(NotAnObject):
        parse_frame(b"[1,2]")


def test_thesis_client_indented_back_to_back_objects() -> None:
    # QJsonDocument::toJson() default (Indented), written back to back without a delimiter
    data = b'{\n    "speed": {\n        "angular": 0,\n        "linear": 0.2\n    }\n}\n{"goal":3}'
    out = JsonStreamDecoder().feed(data)
    assert out == [{"speed": {"angular": 0, "linear": 0.2}}, {"goal": 3}]


def test_tricky_strings_split_at_every_byte() -> None:
    msg = StatusInfo('br{ace} "quo\\"te" \\', "ünï😀 [x] \\\\")
    data = encode(msg) + encode(Goal(1))
    for cut in range(len(data) + 1):
        dec = JsonStreamDecoder()
        out = dec.feed(data[:cut]) + dec.feed(data[cut:])
        assert out == [as_json(msg), {"goal": 1}], cut


def test_one_byte_at_a_time() -> None:
    data = b"".join(encode(m) for m in STATION_EXAMPLES)
    dec = JsonStreamDecoder()
    out: list[Any] = []
    for b in data:
        out += dec.feed(bytes([b]))
    assert out == [as_json(m) for m in STATION_EXAMPLES]


def test_garbage_between_frames_is_reported_and_skipped() -> None:
    dec = JsonStreamDecoder()
    out = dec.feed(b'{"goal":1} hello {"goal":2}}{"goal":3]{"goal":4}  42 "s{x}" {"goal":5}')
    assert out[0] == {"goal": 1}
    assert type(out[1]) is InvalidJson  # "hello"
    assert out[2] == {"goal": 2}
    assert type(out[3]) is InvalidJson  # stray "}"
    assert type(out[4]) is InvalidJson  # {"goal":3] closes at depth 0 but is not JSON
    assert out[5] == {"goal": 4}
    assert type(out[6]) is NotAnObject  # 42: one error for the run up to the next "{"
    assert out[7:] == [{"goal": 5}]


def test_top_level_array_is_rejected_as_a_whole() -> None:
    out = JsonStreamDecoder().feed(b'[{"stop":true}]{"goal":1}[1,')
    assert [type(x) for x in out] == [NotAnObject, dict]
    assert out[1] == {"goal": 1}


def test_frame_at_the_limit_is_accepted_and_one_byte_more_rejected() -> None:
    limit = DEFAULT_MAX_FRAME_BYTES
    overhead = len(b'{"status":{"task":"","message":""}}')
    at_limit = encode(StatusInfo("", "m" * (limit - overhead)))
    assert len(at_limit) == limit + 1  # + newline
    over = encode(StatusInfo("", "m" * (limit - overhead + 1)), max_frame_bytes=limit + 1)
    dec = JsonStreamDecoder()
    out = dec.feed(at_limit + over + b'{"goal":1}')
    assert isinstance(out[0], dict) and len(out[0]["status"]["message"]) == limit - overhead
    assert type(out[1]) is FrameTooLarge
    assert out[2:] == [{"goal": 1}]


def test_oversized_frame_in_small_chunks_is_discarded_without_buffering() -> None:
    dec = JsonStreamDecoder(max_frame_bytes=1000)
    frame = b'{"status":{"task":"{{{","message":"' + b'\\"}' * 2000 + b'"}}'
    data = frame + b'{"goal":2}'
    out: list[Any] = []
    for i in range(0, len(data), 7):
        out += dec.feed(data[i : i + 7])
        assert dec.buffered_bytes <= 1000
    assert [type(x) for x in out] == [FrameTooLarge, dict]
    assert out[1] == {"goal": 2}


def test_unterminated_oversized_frame_keeps_discarding_in_bounded_memory() -> None:
    dec = JsonStreamDecoder(max_frame_bytes=1000)
    assert [type(x) for x in dec.feed(b'{"a":"' + b"x" * 2000)] == [FrameTooLarge]
    for _ in range(100):
        assert dec.feed(b'x{"goal":1}' * 100) == []  # still inside the bad frame's string
        assert dec.buffered_bytes == 0
    assert dec.feed(b'"}{"goal":2}') == [{"goal": 2}]


def test_an_unclosed_string_between_frames_is_given_up_after_the_frame_limit() -> None:
    """A stray quote must not swallow every later frame (the old scanner never gave up)."""
    dec = JsonStreamDecoder(max_frame_bytes=1000)
    assert [type(x) for x in dec.feed(b'x"' + b"a" * 600)] == [InvalidJson]
    assert dec.feed(b"{goal: 1}" + b"a" * 600) == []  # still inside the string: skipped
    assert dec.feed(b'{"goal":2}') == [{"goal": 2}]
    assert dec.buffered_bytes == 0


def test_reset_forgets_a_partial_frame() -> None:
    dec = JsonStreamDecoder()
    assert dec.feed(b'{"goal":') == []
    assert dec.buffered_bytes == 8
    dec.reset()
    assert dec.feed(b'{"goal":1}') == [{"goal": 1}]


def test_decoder_rejects_a_silly_limit() -> None:
    with pytest.raises(ValueError, match="max_frame_bytes"):
        JsonStreamDecoder(max_frame_bytes=0)


# ---- properties -------------------------------------------------------------------------------

_text = st.text(max_size=40)
_node = st.integers(0, 21)
_finite = st.floats(allow_nan=False, allow_infinity=False, width=64)

tablet_messages = st.one_of(
    st.builds(
        Speed,
        st.floats(-0.6, 0.6, allow_nan=False),
        st.floats(-1.0, 1.0, allow_nan=False),
    ),
    st.builds(Goal, _node),
    st.builds(Pause, st.booleans()),
    st.builds(Stop, st.booleans()),
    st.builds(Tour, st.booleans()),
    st.just(Home()),
    st.builds(RequestFrom, _text, _node, _node, st.booleans()),
    st.builds(Hello, st.integers(1, 10), _text),
    st.builds(TourControl, st.sampled_from(["resume", "end"])),
    st.builds(InitialPoseRoom, _node),
    st.builds(
        Malfunction,
        st.sampled_from(["collision", "wrong_position", "wrong_orientation", "other"]),
        _text,
    ),
    st.builds(RequestAnswer, st.integers(0, 2**31 - 1), st.booleans()),
    st.builds(Ping, st.integers(0, 2**53), _finite),
    st.builds(Pong, st.integers(0, 2**53), _finite),
    st.builds(ErrorReport, _text, _text),
)

station_messages = st.one_of(
    st.builds(InitialPose, st.booleans()),
    st.builds(Pose, _finite, _finite, _finite),
    st.builds(GoalStatus, _node, st.booleans(), st.booleans()),
    st.builds(Welcome, st.integers(1, 10), _text),
    st.builds(RobotName, _text),
    st.builds(Refused, _text),
    st.builds(
        TourState,
        st.lists(_node, max_size=8).map(tuple),
        st.lists(_node, max_size=8).map(tuple),
        st.none() | _node,
    ),
    st.builds(ShowRequest, st.integers(0, 99), _text, _node, _node),
    st.builds(Cancel, _text),
    st.builds(Permissions, st.booleans(), st.booleans(), st.booleans(), st.booleans()),
    st.builds(Localisation, st.sampled_from(["unset", "ok", "degraded", "lost", "searching"])),
    st.builds(StatusInfo, _text, _text),
)

_separator = st.sampled_from([b"", b"\n", b" ", b"\r\n", b"\t  \n"])


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts})
    bounds = [0, *points, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds)]


@settings(max_examples=150, deadline=None)
@given(
    msgs=st.lists(st.tuples(tablet_messages, _separator), max_size=12),
    cuts=st.lists(st.integers(0, 10**6), max_size=20),
)
def test_tablet_stream_round_trip(msgs: list[tuple[Message, bytes]], cuts: list[int]) -> None:
    data = b"".join(encode(m).rstrip(b"\n") + sep for m, sep in msgs)
    dec = JsonStreamDecoder()
    out = [x for chunk in _split(data, cuts) for x in dec.feed(chunk)]
    assert all(isinstance(x, dict) for x in out)
    assert [decode_tablet_message(x, LIMITS) for x in out] == [m for m, _ in msgs]
    assert dec.buffered_bytes == 0


@settings(max_examples=150, deadline=None)
@given(
    msgs=st.lists(st.tuples(station_messages, _separator), max_size=12),
    cuts=st.lists(st.integers(0, 10**6), max_size=20),
)
def test_station_stream_round_trip(msgs: list[tuple[Message, bytes]], cuts: list[int]) -> None:
    data = b"".join(encode(m).rstrip(b"\n") + sep for m, sep in msgs)
    dec = JsonStreamDecoder()
    out = [x for chunk in _split(data, cuts) for x in dec.feed(chunk)]
    assert [decode_station_message(x, LIMITS) for x in out] == [m for m, _ in msgs]


# Garbage that cannot open a frame or a string: any bytes except "{", "[" and '"'.
_garbage = st.binary(min_size=1, max_size=30).filter(
    lambda b: not set(b) & set(b'{["') and b.strip() != b""
)


@settings(max_examples=150, deadline=None)
@given(
    parts=st.lists(st.tuples(tablet_messages, st.none() | _garbage), min_size=1, max_size=8),
    cuts=st.lists(st.integers(0, 10**6), max_size=10),
)
def test_garbage_between_frames_resyncs(
    parts: list[tuple[Message, bytes | None]], cuts: list[int]
) -> None:
    data = b"".join((g or b"") + encode(m) for m, g in parts)
    dec = JsonStreamDecoder()
    out = [x for chunk in _split(data, cuts) for x in dec.feed(chunk)]
    assert [x for x in out if isinstance(x, dict)] == [as_json(m) for m, _ in parts]
    errors = [x for x in out if isinstance(x, ProtocolError)]
    assert len(errors) == sum(g is not None for _, g in parts)
    assert all(isinstance(e, InvalidJson) for e in errors)


@settings(max_examples=200, deadline=None)
@given(chunks=st.lists(st.binary(max_size=300), max_size=20), limit=st.integers(2, 256))
def test_random_bytes_never_raise_and_stay_within_the_memory_bound(
    chunks: list[bytes], limit: int
) -> None:
    dec = JsonStreamDecoder(max_frame_bytes=limit)
    for chunk in chunks:
        for item in dec.feed(chunk):
            assert isinstance(item, dict | ProtocolError)
            if isinstance(item, dict):
                assert len(json.dumps(item).encode()) > 0
        assert dec.buffered_bytes <= limit
