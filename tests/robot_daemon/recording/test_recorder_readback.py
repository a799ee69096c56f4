"""A short synthetic run recorded to MCAP and read back with the reference `mcap` reader.

The run: 6 s of daemon time with scans at 40 Hz, pose and odometry at 20 Hz, the camera at
10 Hz (real JPEGs), the battery at 1 Hz, the map once, a route command and a planned path.
"""

from __future__ import annotations

import json
import math
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from mcap.reader import make_reader

from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.topics import (
    Battery,
    ImageMsg,
    Lock,
    MuxMsg,
    Odom,
    PlanMsg,
    PoseMsg,
    RouteMsg,
    Status,
    Topic,
    Twist,
)
from robot_daemon.config import DEFAULT_MAP
from robot_daemon.recording import foxglove_convert as fc
from robot_daemon.recording.recorder import Recorder

DURATION = 6.0  # [s]
SCAN_HZ, POSE_HZ, CAMERA_HZ, BATTERY_HZ = 40, 20, 10, 1
EPOCH = 1.7e9  # [s] wall time of daemon time zero


def _scan(t: float, rng: np.random.Generator) -> LaserScan:
    ranges = rng.uniform(0.5, 8.0, 721).astype(np.float32)
    ranges[::50] = 0.0  # no return: below range_min
    return LaserScan(t, -math.pi / 2, math.pi / 720, 0.02, 30.0, ranges)


def _jpeg(i: int) -> bytes:
    image = np.full((120, 160, 3), (i * 7) % 255, np.uint8)
    ok, data = cv2.imencode(".jpg", image)
    assert ok
    return bytes(data)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    grid = load_map(DEFAULT_MAP)
    rng = np.random.default_rng(5)
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    scans: list[LaserScan] = []
    with Recorder("r1", single_file=path, epoch_offset=EPOCH, queue_size=100_000) as recorder:
        recorder.state(Topic.MAP, grid, 0.0)
        recorder.command(Topic.ROUTE, RouteMsg(7, ((1.0, 2.0, 0.0), (3.0, 2.0, 1.0))), 0.0)
        recorder.command(Topic.STOP, Lock(True, 0.5), 0.5)
        recorder.state(Topic.PLAN, PlanMsg(7, ((0.0, 0.0), (1.0, 1.0), (2.0, 1.0)), 0.1), 0.1)
        for i in range(int(DURATION * SCAN_HZ)):
            t = i / SCAN_HZ
            scans.append(_scan(t, rng))
            recorder.state(Topic.SCAN, scans[-1], t)
            if i % (SCAN_HZ // POSE_HZ) == 0:
                recorder.state(Topic.POSE, PoseMsg(1.0 + 0.1 * t, 2.0, 0.3, t, "ok", 0.9), t)
                recorder.state(Topic.ODOM, Odom(0.1 * t, 0.0, 0.1, 0.1, 0.0, t), t)
                recorder.state(Topic.CMD_VEL, Twist(0.1, 0.0, t), t)
                recorder.state(Topic.MUX, MuxMsg("planner_vel", "", (), 0.1, 0.0, t), t)
            if i % (SCAN_HZ // CAMERA_HZ) == 0:
                recorder.state(Topic.IMAGE, ImageMsg(t, 160, 120, _jpeg(i)), t)
            if i % (SCAN_HZ // BATTERY_HZ) == 0:
                recorder.state(Topic.BATTERY, Battery(24.0, 1.0, 0.8, t), t)
        recorder.state(Topic.STATUS, Status("warning", "localisation degraded", stamp=3.0), 3.0)
    stats = recorder.stats()
    messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        schemas = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            messages[channel.topic].append((message.log_time, message.data))
            schemas[channel.topic] = (schema.name if schema else None, channel.message_encoding)
            if schema is not None and schema.encoding == "protobuf":
                schemas[channel.topic + "#descriptor"] = schema.data
    return {
        "grid": grid,
        "scans": scans,
        "stats": stats,
        "messages": messages,
        "schemas": schemas,
        "summary": summary,
    }


def test_every_channel_is_present_with_its_schema(run: dict[str, Any]) -> None:
    schemas = run["schemas"]
    expected = {
        "/map": ("foxglove.Grid", "protobuf"),
        "/scan": ("foxglove.LaserScan", "protobuf"),
        "/tf": ("foxglove.FrameTransforms", "protobuf"),
        "/tf_static": ("foxglove.FrameTransforms", "protobuf"),
        "/route": ("foxglove.PosesInFrame", "protobuf"),
        "/planned_path": ("foxglove.PosesInFrame", "protobuf"),
        "/camera/image/compressed": ("foxglove.CompressedImage", "protobuf"),
        "/pose": ("PoseMsg", "json"),
        "/odom": ("Odom", "json"),
        "/cmd_vel": ("Twist", "json"),
        "/mux": ("MuxMsg", "json"),
        "/battery": ("Battery", "json"),
        "/status": ("Status", "json"),
        "/plan": ("PlanMsg", "json"),
        "/commands": ("interbotCommands", "json"),
    }
    assert {t: s for t, s in schemas.items() if not t.endswith("#descriptor")} == expected
    assert run["stats"]["dropped"] == 0 and run["stats"]["errors"] == 0


def test_message_counts_match_duration_and_rates(run: dict[str, Any]) -> None:
    counts = Counter({topic: len(msgs) for topic, msgs in run["messages"].items()})
    assert counts["/scan"] == DURATION * SCAN_HZ
    assert counts["/pose"] == counts["/odom"] == counts["/cmd_vel"] == DURATION * POSE_HZ
    # One map->odom->base_link per odometry, and one from the first pose (before any odometry).
    assert counts["/tf"] == DURATION * POSE_HZ + 1
    assert counts["/camera/image/compressed"] == DURATION * CAMERA_HZ
    assert counts["/battery"] == DURATION * BATTERY_HZ
    assert counts["/map"] == counts["/route"] == counts["/planned_path"] == counts["/plan"] == 1
    assert counts["/commands"] == 2
    stats = run["summary"].statistics
    assert stats.message_count == sum(counts.values())


def test_timestamps_are_monotonic_and_on_the_epoch(run: dict[str, Any]) -> None:
    for topic, msgs in run["messages"].items():
        times = [t for t, _ in msgs]
        assert times == sorted(times), topic
        assert all(EPOCH * 1e9 <= t <= (EPOCH + DURATION) * 1e9 for t in times), topic
    scan_times = np.array([t for t, _ in run["messages"]["/scan"]]) / 1e9 - EPOCH
    np.testing.assert_allclose(np.diff(scan_times), 1 / SCAN_HZ, atol=1e-6)


def _decoded(run: dict[str, Any], topic: str, index: int) -> Any:
    """Message ``index`` of ``topic``, read with the protobuf class of its recorded schema."""
    name, _ = run["schemas"][topic]
    cls = fc.message_class(name, run["schemas"][topic + "#descriptor"])
    return cls.FromString(run["messages"][topic][index][1])


def test_map_decodes_to_the_same_grid(run: dict[str, Any]) -> None:
    grid: OccupancyGrid = run["grid"]
    decoded = fc.grid_from(_decoded(run, "/map", 0))
    assert decoded.cells.shape == grid.cells.shape
    assert np.array_equal(decoded.cells, grid.cells)
    assert (decoded.resolution, decoded.origin_x, decoded.origin_y) == (
        grid.resolution,
        grid.origin_x,
        grid.origin_y,
    )


def test_scans_decode_with_invalid_beams_as_nan(run: dict[str, Any]) -> None:
    original: LaserScan = run["scans"][3]
    decoded = fc.scan_from(_decoded(run, "/scan", 3), 0.02, 30.0)
    valid = original.valid()
    np.testing.assert_allclose(decoded.ranges[valid], original.ranges[valid], rtol=1e-6)
    assert np.isnan(decoded.ranges[~valid]).all()
    assert decoded.angle_min == pytest.approx(original.angle_min)
    assert decoded.angle_increment == pytest.approx(original.angle_increment)
    assert decoded.stamp == pytest.approx(EPOCH + 3 / SCAN_HZ)


def test_the_recorded_schemas_describe_their_messages(run: dict[str, Any]) -> None:
    """The replay decodes with the descriptors in the file: each reads its channel losslessly."""
    for topic in ("/map", "/scan", "/camera/image/compressed", "/tf", "/route"):
        message = _decoded(run, topic, 0)
        assert message.DESCRIPTOR.full_name == run["schemas"][topic][0]
        assert message.SerializeToString() == run["messages"][topic][0][1], topic


def test_transforms_chain_map_odom_base_link(run: dict[str, Any]) -> None:
    transforms = _decoded(run, "/tf", 10).transforms
    frames = [(t.parent_frame_id, t.child_frame_id) for t in transforms]
    assert frames == [("map", "odom"), ("odom", "base_link")]


def test_commands_say_who_asked_for_what(run: dict[str, Any]) -> None:
    commands = [json.loads(d) for _, d in run["messages"]["/commands"]]
    assert commands[0]["topic"] == "route" and commands[0]["source"] == "station"
    assert commands[0]["message"]["route_id"] == 7
    assert commands[1] == {
        "topic": "stop",
        "source": "station",
        "stamp": 0.5,
        "message": {"engaged": True, "stamp": 0.5},
    }


def test_the_camera_frames_are_the_jpegs(run: dict[str, Any]) -> None:
    image = _decoded(run, "/camera/image/compressed", 2)
    assert image.format == "jpeg" and image.data == _jpeg(2 * SCAN_HZ // CAMERA_HZ)
    assert fc.seconds(image.timestamp) == pytest.approx(EPOCH + 0.2)


def test_a_recording_goes_to_a_new_directory_and_its_json_is_strict(tmp_path: Path) -> None:
    path = tmp_path / "deep" / "er" / "x.mcap"
    with Recorder("r1", single_file=path) as recorder:
        recorder.json("/truth", {"x": 1.0, "nan": math.nan, "v": (math.inf, 2)}, 0.0)
    with path.open("rb") as f:
        messages = [(c.topic, m.data) for _, c, m in make_reader(f).iter_messages()]
    assert [topic for topic, _ in messages] == ["/truth"]

    def strict(name: str) -> None:
        raise ValueError(f"{name} is not JSON")

    # NaN and infinity are not JSON: they are recorded as null.
    assert json.loads(messages[0][1], parse_constant=strict) == {
        "x": 1.0,
        "nan": None,
        "v": [None, 2],
    }
