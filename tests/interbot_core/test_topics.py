"""Keys and codecs of the zenoh link (interbot_core.topics): round trips and rejection."""

from __future__ import annotations

import contextlib
import json
import math
import struct
import zlib

import msgspec
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.topics import (
    ALIVE_WILDCARD,
    COMMAND_TOPICS,
    MAX_IMAGE_BYTES,
    MAX_JSON_BYTES,
    STATE_TOPICS,
    TOPIC_SPECS,
    AssistMsg,
    Battery,
    ConfigMsg,
    GoalMsg,
    ImageMsg,
    InitialPose,
    Lock,
    MessageValueError,
    MuxMsg,
    Odom,
    PoseMsg,
    RangeEncoding,
    RobotIdError,
    RouteMsg,
    RouteProgress,
    SafetyMsg,
    StandingNotices,
    Status,
    StopRelease,
    Topic,
    TopicDecodeError,
    TopicError,
    Twist,
    alive_key,
    decode,
    decode_image,
    decode_map,
    decode_scan,
    decode_snapshot,
    encode,
    encode_image,
    encode_map,
    encode_scan,
    encode_snapshot,
    key,
    parse_key,
    state_key,
    validate_robot_id,
)

# ------------------------------------------------------------------ keys


def test_keys_follow_interbot_robot_topic() -> None:
    assert key("interbot_1", Topic.STATION_VEL) == "interbot/interbot_1/station_vel"
    assert key("r-2", "scan") == "interbot/r-2/scan"
    assert alive_key("r1") == "interbot/r1/alive"
    assert state_key("r1") == "interbot/r1/state"
    assert ALIVE_WILDCARD == "interbot/*/alive"
    assert parse_key("interbot/r1/pose") == ("r1", "pose")


@pytest.mark.parametrize("bad", ["", "a" * 33, "r/1", "r*", "r 1", "**", "röbot", "r$"])
def test_invalid_robot_ids_are_refused(bad: str) -> None:
    with pytest.raises(RobotIdError, match="1-32 characters"):
        validate_robot_id(bad)
    with pytest.raises(RobotIdError):
        key(bad, Topic.POSE)


def test_unknown_topic_and_foreign_keys_are_refused() -> None:
    with pytest.raises(TopicError, match="unknown topic 'velocity'"):
        key("r1", "velocity")
    for bad in ("other/r1/pose", "interbot/r1", "interbot/r1/pose/x"):
        with pytest.raises(TopicError):
            parse_key(bad)


def test_every_topic_has_one_spec_and_direction() -> None:
    assert set(TOPIC_SPECS) == set(Topic)
    assert set(Topic) == COMMAND_TOPICS | STATE_TOPICS
    assert not COMMAND_TOPICS & STATE_TOPICS
    must_arrive = {t for t, s in TOPIC_SPECS.items() if s.must_arrive}
    assert {Topic.STOP, Topic.ROUTE, Topic.INITIAL_POSE, Topic.STOP_RELEASE} <= must_arrive
    assert {Topic.SCAN, Topic.POSE, Topic.IMAGE, Topic.STATION_VEL}.isdisjoint(must_arrive)


# ------------------------------------------------------------------ JSON messages

EXAMPLES = {
    Topic.STATION_VEL: Twist(0.3, -0.5, 12.5),
    Topic.TABLET_VEL: Twist(-0.1, 0.0),
    Topic.PAUSE_NAV: Lock(True, 3.0),
    Topic.STOP: Lock(False),
    Topic.STOP_RELEASE: StopRelease("operator at station", 4.0),
    Topic.ROUTE: RouteMsg(7, ((0.0, 0.0, 0.0), (5.5, -2.0, math.pi)), (3, 9), 0.6, 0.2, 0.3),
    Topic.GOAL: GoalMsg(1.0, 2.0, -1.0, node_id=4, stamp=1.0),
    Topic.INITIAL_POSE: InitialPose(12.0, 3.5, 1.57),
    Topic.CONFIG: ConfigMsg({"max_linear": 0.5, "inflation.radius": 0.6, "use_dwa": True, "n": 3}),
    Topic.CMD_VEL: Twist(0.2, 0.1, 99.0),
    Topic.POSE: PoseMsg(1.0, -2.0, 0.5, 10.0, "lost", 0.25),
    Topic.ODOM: Odom(0.5, 0.25, -0.1, 0.3, 0.05, 10.0),
    Topic.ROUTE_PROGRESS: RouteProgress(7, 1, False, "aborted", "no progress for 10 s", 3.0),
    Topic.BATTERY: Battery(25.9, 2.1, 0.8, 1.0),
    Topic.STATUS: Status("warning", "localisation lost", "guided tour", 12.5, 2.0),
    Topic.MUX: MuxMsg(None, "stop lock engaged", ("stop",), 0.0, 0.0, 5.0),
    Topic.TELEOP_ASSIST: AssistMsg("station_vel", True, 2.0),
    Topic.SAFETY: SafetyMsg("stop", "FootprintStop", 0.03, 0.1, 0.0, ("tablet_vel",), "slid", 3.0),
    Topic.NOTICES: StandingNotices((Status("info", "walls learnt at cell centres", stamp=4.5),)),
}


@pytest.mark.parametrize("topic", list(EXAMPLES), ids=str)
def test_json_messages_round_trip_exactly(topic: Topic) -> None:
    message = EXAMPLES[topic]
    payload = encode(topic, message)
    assert decode(topic, payload) == message
    assert encode(topic, decode(topic, payload)) == payload
    assert isinstance(json.loads(payload), dict)


def test_json_with_integers_and_omitted_defaults_decodes() -> None:
    pose = decode(Topic.POSE, b'{"x": 1, "y": 2, "yaw": 0}')
    assert pose == PoseMsg(1.0, 2.0, 0.0, 0.0, "ok", 1.0)
    assert isinstance(pose, PoseMsg) and isinstance(pose.x, float)


@pytest.mark.parametrize(
    ("topic", "payload", "match"),
    [
        (Topic.POSE, b'{"x": NaN, "y": 0, "yaw": 0}', "NaN"),
        (Topic.POSE, b'{"x": 1e9, "y": 0, "yaw": 0}', r"PoseMsg\.x"),
        (Topic.POSE, b'{"x": 0, "y": 0, "yaw": 4.0}', r"PoseMsg\.yaw"),
        (Topic.POSE, b'{"x": 0, "y": 0, "yaw": 0, "state": "happy"}', "unset"),
        (Topic.POSE, b'{"x": 0, "y": 0, "yaw": 0, "confidence": 1.5}', "confidence"),
        (Topic.POSE, b'{"x": 0, "y": 0}', "yaw"),
        (Topic.POSE, b'{"x": 0, "y": 0, "yaw": 0, "z": 1}', "PoseMsg.z is not a field"),
        (Topic.POSE, b"[1, 2, 3]", "must be an object"),
        (Topic.POSE, b"\xff\xfe", "UTF-8"),
        (Topic.STATION_VEL, b'{"linear": 9.0, "angular": 0}', "linear"),
        (Topic.STATION_VEL, b'{"linear": true, "angular": 0}', "number"),
        (Topic.STATION_VEL, b'{"linear": "0.1", "angular": 0}', "number"),
        (Topic.STOP, b'{"engaged": 1}', "true or false"),
        (Topic.ROUTE, b'{"route_id": 1, "waypoints": []}', "1..1024"),
        (Topic.ROUTE, b'{"route_id": 1, "waypoints": [[0, 0]]}', r"waypoints\[0\]"),
        (Topic.ROUTE, b'{"route_id": 1, "waypoints": [[0, 0, 0]], "node_ids": [1, 2]}', "node_ids"),
        (Topic.ROUTE, b'{"route_id": -1, "waypoints": [[0, 0, 0]]}', "route_id"),
        (Topic.ROUTE, b'{"route_id": 1, "waypoints": [[0,0,0]], "goal_tolerance": 0}', "goal_tol"),
        (Topic.ROUTE_PROGRESS, b'{"route_id": 1, "index": 0, "state": "lost"}', "state"),
        (Topic.BATTERY, b'{"voltage": 24, "soc": 2}', "soc"),
        (Topic.STATUS, b'{"level": "panic", "text": ""}', "level"),
        (Topic.CONFIG, b'{"params": {}}', "1..1024"),
        (Topic.CONFIG, b'{"params": {"Bad Name": 1}}', "key 'Bad Name' must be a str matching"),
        (Topic.CONFIG, b'{"params": {"a": [1]}}', r"params\.a must be true or false or an int"),
        (Topic.GOAL, b'{"x": 0, "y": 0, "yaw": 0, "node_id": 1.5}', "node_id"),
    ],
)
def test_invalid_json_is_rejected_naming_the_field(
    topic: Topic, payload: bytes, match: str
) -> None:
    with pytest.raises(TopicDecodeError, match=match) as info:
        decode(topic, payload)
    assert str(info.value).startswith(f"{topic}:")


def test_oversized_json_is_rejected_before_parsing() -> None:
    payload = b'{"x": 0, "y": 0, "yaw": 0, "pad": "' + b"a" * MAX_JSON_BYTES + b'"}'
    with pytest.raises(TopicDecodeError, match="bytes >"):
        decode(Topic.POSE, payload)


def test_constructors_refuse_invalid_values() -> None:
    with pytest.raises(MessageValueError, match=r"Twist\.angular"):
        Twist(0.0, math.inf)
    with pytest.raises(MessageValueError, match=r"Battery\.voltage"):
        Battery(-1.0)
    with pytest.raises(MessageValueError, match="params"):
        ConfigMsg({"x": math.nan})


def test_encode_checks_the_message_type_of_the_topic() -> None:
    with pytest.raises(MessageValueError, match="stop carries Lock, not Twist"):
        encode(Topic.STOP, Twist(0.0, 0.0))
    with pytest.raises(MessageValueError, match="cannot encode"):
        encode(Topic.SCAN, Twist(0.0, 0.0))


finite = st.floats(-1e5, 1e5, allow_nan=False)
yaws = st.floats(-math.pi, math.pi, allow_nan=False)
stamps = st.floats(0.0, 1e9, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(
    wps=st.lists(st.tuples(finite, finite, yaws), min_size=1, max_size=30),
    rid=st.integers(0, 2**53),
    tol=st.floats(1e-3, 100.0),
)
def test_route_round_trip_property(
    wps: list[tuple[float, float, float]], rid: int, tol: float
) -> None:
    route = RouteMsg(rid, tuple(wps), tuple(range(len(wps))), tol, tol, min(tol, math.pi))
    assert decode(Topic.ROUTE, encode(Topic.ROUTE, route)) == route


@settings(max_examples=100, deadline=None)
@given(x=finite, y=finite, yaw=yaws, stamp=stamps, conf=st.floats(0.0, 1.0))
def test_pose_round_trip_property(
    x: float, y: float, yaw: float, stamp: float, conf: float
) -> None:
    pose = PoseMsg(x, y, yaw, stamp, "ok", conf)
    assert decode(Topic.POSE, encode(Topic.POSE, pose)) == pose


@settings(max_examples=200, deadline=None)
@given(payload=st.binary(max_size=200))
def test_random_bytes_never_crash_any_decoder(payload: bytes) -> None:
    for topic in Topic:
        with contextlib.suppress(TopicDecodeError):
            decode(topic, payload)


# ------------------------------------------------------------------ binary messages


def _scan(n: int = 1081) -> LaserScan:
    ranges = np.linspace(0.05, 35.0, n).astype(np.float32)
    ranges[3] = np.nan
    ranges[4] = np.inf
    return LaserScan(12.25, -math.radians(135), math.radians(0.25), 0.1, 30.0, ranges)


def test_scan_float32_round_trips_bit_exactly() -> None:
    scan = _scan()
    payload = encode_scan(scan)
    assert len(payload) == 49 + 4 * 1081
    back = decode_scan(payload)
    assert back.ranges.tobytes() == scan.ranges.tobytes()
    assert (back.stamp, back.angle_min, back.angle_increment) == (
        scan.stamp,
        scan.angle_min,
        scan.angle_increment,
    )
    assert (back.range_min, back.range_max) == (scan.range_min, scan.range_max)


def test_scan_millimetres_round_to_half_a_millimetre_and_mark_no_return() -> None:
    scan = _scan()
    back = decode_scan(encode_scan(scan, RangeEncoding.UINT16_MM))
    valid = scan.valid()
    assert np.max(np.abs(back.ranges[valid] - scan.ranges[valid])) <= 0.0005 + 1e-6
    assert np.all(np.isnan(back.ranges[~valid]))
    assert len(encode_scan(scan, RangeEncoding.UINT16_MM)) == 49 + 2 * 1081


@settings(max_examples=50, deadline=None)
@given(
    ranges=st.lists(st.floats(width=32, allow_nan=True), min_size=1, max_size=300),
    stamp=stamps,
)
def test_scan_round_trip_property(ranges: list[float], stamp: float) -> None:
    scan = LaserScan(stamp, -1.0, 0.01, 0.0, 60.0, np.array(ranges, dtype=np.float32))
    back = decode_scan(encode_scan(scan))
    assert back.ranges.tobytes() == scan.ranges.tobytes() and back.stamp == stamp


def test_truncated_oversized_and_wrong_version_scans_are_rejected() -> None:
    payload = encode_scan(_scan())
    with pytest.raises(TopicDecodeError, match="expected"):
        decode_scan(payload[:-1])
    with pytest.raises(TopicDecodeError, match="expected"):
        decode_scan(payload + b"\0")
    with pytest.raises(TopicDecodeError, match="truncated header"):
        decode_scan(payload[:10])
    with pytest.raises(TopicDecodeError, match="version 2 unsupported"):
        decode_scan(payload[:2] + b"\x02" + payload[3:])
    with pytest.raises(TopicDecodeError, match="bad magic"):
        decode_scan(b"XX" + payload[2:])
    with pytest.raises(TopicDecodeError, match="kind 2"):
        decode_scan(payload[:3] + b"\x02" + payload[4:])
    huge = struct.pack("<2sBBdddddBI", b"IB", 1, 1, 0, 0, 0.01, 0, 1, 0, 100000)
    with pytest.raises(TopicDecodeError, match="beam count"):
        decode_scan(huge)


def _grid() -> OccupancyGrid:
    rng = np.random.default_rng(3)
    cells = rng.choice(np.array([-1, 0, 100, 42], dtype=np.int8), size=(37, 53))
    return OccupancyGrid(cells, 0.05, -3.5, 1.25, 0.0)


def test_map_round_trips_exactly_and_compresses() -> None:
    grid = _grid()
    back = decode_map(encode_map(grid))
    assert back.cells.dtype == np.int8 and np.array_equal(back.cells, grid.cells)
    assert (back.resolution, back.origin_x, back.origin_y, back.origin_yaw) == (
        0.05,
        -3.5,
        1.25,
        0.0,
    )
    free = OccupancyGrid(np.zeros((945, 1165), np.int8), 0.05, 0.0, 0.0)
    assert len(encode_map(free)) < 5000


def test_bad_maps_are_rejected() -> None:
    payload = encode_map(_grid())
    with pytest.raises(TopicDecodeError, match="header says"):
        decode_map(payload[:-3])
    with pytest.raises(TopicDecodeError, match="version"):
        decode_map(payload[:2] + b"\x09" + payload[3:])
    head = struct.Struct("<2sBBddddIII")
    # A zip bomb: the header claims 2x2 cells, the data inflates to a megabyte.
    bomb = zlib.compress(b"\0" * 1_000_000)
    with pytest.raises(TopicDecodeError, match="exactly 2x2"):
        decode_map(head.pack(b"IB", 1, 2, 0.05, 0, 0, 0, 2, 2, len(bomb)) + bomb)
    bad_cells = zlib.compress(np.array([0, 0, 0, 101], np.int8).tobytes())
    with pytest.raises(TopicDecodeError, match=r"-1 \(unknown\) or 0\.\.100"):
        decode_map(head.pack(b"IB", 1, 2, 0.05, 0, 0, 0, 2, 2, len(bad_cells)) + bad_cells)
    ok = zlib.compress(b"\0" * 4)
    with pytest.raises(TopicDecodeError, match="resolution"):
        decode_map(head.pack(b"IB", 1, 2, -1.0, 0, 0, 0, 2, 2, len(ok)) + ok)
    with pytest.raises(TopicDecodeError, match="corrupt zlib"):
        decode_map(head.pack(b"IB", 1, 2, 0.05, 0, 0, 0, 2, 2, 4) + b"abcd")
    with pytest.raises(TopicDecodeError, match="cells outside"):
        decode_map(head.pack(b"IB", 1, 2, 0.05, 0, 0, 0, 0, 2, len(ok)) + ok)


JPEG = b"\xff\xd8\xff\xe0" + bytes(range(256)) + b"\xff\xd9"


def test_image_round_trips_and_rejects_non_jpeg() -> None:
    image = ImageMsg(3.5, 640, 480, JPEG)
    payload = encode_image(image)
    assert decode(Topic.IMAGE, payload) == image
    with pytest.raises(TopicDecodeError, match="truncated"):
        decode_image(payload[:-1])
    with pytest.raises(TopicDecodeError, match="JPEG"):
        decode_image(payload[: -len(JPEG)] + b"PNG." + JPEG[4:])
    zero_width = msgspec.msgpack.encode({"stamp": 1.0, "width": 0, "height": 3, "jpeg": JPEG})
    with pytest.raises(TopicDecodeError, match=r"image\.width = 0 is outside .* 1\.\.65535"):
        decode_image(payload[:4] + zero_width)
    with pytest.raises(TopicDecodeError, match="more than a JPEG may have"):
        decode_image(payload[:4] + bytes(MAX_IMAGE_BYTES + 64))
    with pytest.raises(MessageValueError, match="width"):
        ImageMsg(0.0, 0, 480, JPEG)


def test_snapshot_carries_parts_and_rejects_corruption() -> None:
    parts = {
        Topic.MAP: encode_map(_grid()),
        Topic.POSE: encode(Topic.POSE, EXAMPLES[Topic.POSE]),
    }
    payload = encode_snapshot(parts)
    back = decode_snapshot(payload)
    assert back == parts
    assert decode(Topic.POSE, back[Topic.POSE]) == EXAMPLES[Topic.POSE]
    assert decode_snapshot(encode_snapshot({})) == {}
    with pytest.raises(TopicDecodeError, match="truncated"):
        decode_snapshot(payload[:-1])
    with pytest.raises(TopicDecodeError, match="trailing"):
        decode_snapshot(payload + b"x")
    renamed = payload.replace(b"\xa4pose", b"\xa4pise")  # a MessagePack string of 4
    with pytest.raises(TopicDecodeError, match="unknown topic"):
        decode_snapshot(renamed)


def test_pose_covariance_and_degraded_state_round_trip_and_are_validated() -> None:
    """The localiser's 3x3 covariance rides on the pose topic (row-major, 9 numbers)."""
    cov = (0.01, 0.002, 0.0, 0.002, 0.09, 0.0, 0.0, 0.0, 0.0004)
    msg = PoseMsg(1.0, 2.0, 0.3, 5.0, "degraded", 0.8, cov)
    assert decode(Topic.POSE, encode(Topic.POSE, msg)) == msg
    assert msg.sigmas == pytest.approx((0.1, 0.3, 0.02))
    assert PoseMsg(0.0, 0.0, 0.0).sigmas is None  # older senders: no covariance
    for state in ("unset", "ok", "degraded", "lost", "searching", "turning"):
        assert PoseMsg(0.0, 0.0, 0.0, state=state).state == state


def test_a_pose_is_known_unless_unset_or_a_search_before_any_pose() -> None:
    """A start-up search (issue 16) has no pose yet: the daemon sends it with no covariance."""
    cov = (0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.001)
    assert not PoseMsg(0.0, 0.0, 0.0, state="unset").known
    for state in ("searching", "turning"):
        assert not PoseMsg(0.0, 0.0, 0.0, state=state, confidence=0.0).known
        assert PoseMsg(1.0, 2.0, 0.0, state=state, covariance=cov).known  # after a kidnap
        assert PoseMsg(1.0, 2.0, 0.0, state=state).known  # older senders: no covariance
    for state in ("ok", "degraded", "lost"):
        assert PoseMsg(1.0, 2.0, 0.0, state=state).known  # older senders: no covariance
    for bad in ((0.0,) * 4, (-1.0,) + (0.0,) * 8, (math.nan,) * 9, (2e6,) + (0.0,) * 8):
        with pytest.raises(MessageValueError, match="covariance"):
            PoseMsg(0.0, 0.0, 0.0, covariance=bad)
    with pytest.raises(TopicDecodeError):
        decode(Topic.POSE, b'{"x": 0, "y": 0, "yaw": 0, "covariance": [1, 2]}')
