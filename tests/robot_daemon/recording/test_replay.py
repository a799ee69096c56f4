"""``interbot replay``: a daemon's recording played back as a robot the station watches."""

from __future__ import annotations

import socket
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.replay_control import ReplayCommand
from interbot_core.topics import ImageMsg, PoseMsg, Status, Topic
from interbot_link import StationLink, open_session
from interbot_link.replay import ReplayControlClient
from robot_daemon.config import DEFAULT_MAP
from robot_daemon.recording.replay import (
    RecordingSource,
    ReplayFileError,
    ReplayItem,
    ReplayPlayer,
    serve_replay,
)

pytestmark = pytest.mark.timeout(120)


def test_the_source_decodes_the_recording(daemon_recording: Path) -> None:
    source = RecordingSource(daemon_recording)
    try:
        assert source.robot_id == "recbot"
        assert source.duration >= 5.0  # the fixture runs the daemon past 6 s of robot time
        items = list(source.items())
        kinds = Counter(item.topic for item in items)
        assert {Topic.POSE, Topic.ODOM, Topic.SCAN, Topic.MAP, Topic.IMAGE, Topic.STATUS} <= set(
            kinds
        )
        times = [item.t for item in items]
        assert times == sorted(times) and times[0] >= 0.0 and times[-1] <= source.duration
        grid = next(i.message for i in items if i.topic is Topic.MAP)
        assert isinstance(grid, OccupancyGrid)
        assert np.array_equal(grid.cells, load_map(DEFAULT_MAP).cells)
        image = next(i.message for i in items if i.topic is Topic.IMAGE)
        assert isinstance(image, ImageMsg) and image.width > 0 and image.jpeg[:2] == b"\xff\xd8"
        lines = [i.message.text for i in items if isinstance(i.message, Status)]
        assert any(line.startswith("replay: station sent route") for line in lines)
        assert source.decode_errors == 0
    finally:
        source.close()


def test_the_player_follows_its_clock(daemon_recording: Path) -> None:
    source = RecordingSource(daemon_recording)
    try:
        _follow_the_clock(source)
    finally:
        source.close()


def _follow_the_clock(source: RecordingSource) -> None:
    published: list[ReplayItem] = []
    player = ReplayPlayer(source, published.append, now=0.0, speed=2.0)
    player.step(1.0)  # 2 s of recording
    assert published and all(item.t <= 2.0 for item in published)
    assert published[0].topic is Topic.MAP
    count = len(published)
    player.command(ReplayCommand("pause"), 1.0)
    player.step(5.0)
    assert len(published) == count
    player.command(ReplayCommand("seek", 5.0), 5.0)
    after_seek = published[count:]
    assert [i.topic for i in after_seek[:2]] == [Topic.MAP, Topic.POSE]  # drawn at once
    player.command(ReplayCommand("speed", 20.0), 5.0)
    player.command(ReplayCommand("play"), 5.0)
    player.step(5.05)  # 1 s of recording at x20: everything up to t = 6.0, nothing after
    shown = published[count:]
    assert max(i.t for i in shown) <= 6.0 + 1e-6
    due = {(i.topic, i.t) for i in source.items(5.0) if i.t <= 6.0 - 1e-6}
    assert due <= {(i.topic, i.t) for i in shown}  # however the recording's messages fall
    player.command(ReplayCommand("seek", 0.5), 6.0)
    before = len(published)
    player.step(100.0)  # far behind: stale scans and frames skipped, nothing else
    assert published[-1].t == pytest.approx(source.duration, abs=0.05)
    late = published[before:]
    assert player.skipped > 0
    assert all(i.t >= source.duration - 1.0 for i in late if i.topic in (Topic.SCAN, Topic.IMAGE))
    assert any(i.topic is Topic.POSE and i.t < source.duration - 1.0 for i in late)


def test_a_truncated_recording_is_refused(daemon_recording: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    data = daemon_recording.read_bytes()
    cut.write_bytes(data[: len(data) // 2])  # however long the recording, half of it
    with pytest.raises(ReplayFileError, match=r"cut short|not an MCAP"):
        RecordingSource(cut)


def test_the_station_watches_and_controls_a_replay(
    daemon_recording: Path, query_state: Callable[..., dict[Topic, object]]
) -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        endpoint = f"tcp/127.0.0.1:{sock.getsockname()[1]}"
    stop = threading.Event()
    ready = threading.Event()
    thread = threading.Thread(
        target=serve_replay,
        args=(daemon_recording, [endpoint], [], stop),
        kwargs={
            "robot_id": "replay1",
            "speed": 20.0,
            "paused": True,
            "ready": lambda _: ready.set(),
        },
        daemon=True,
    )
    thread.start()
    try:
        assert ready.wait(20.0)
        with open_session([], [endpoint]) as session:
            station = StationLink(session)
            control = ReplayControlClient(session)
            deadline = time.monotonic() + 10.0
            while "replay1" not in station.robots and time.monotonic() < deadline:
                time.sleep(0.01)
            station.select_robot("replay1")
            states = {}
            while "replay1" not in states and time.monotonic() < deadline:
                states.update(control.poll_states())
                time.sleep(0.01)
            assert not states["replay1"].playing and states["replay1"].speed == 20.0
            control.send("replay1", ReplayCommand("play"))
            poses: list[PoseMsg] = []
            while time.monotonic() < deadline + 10.0:
                station.poll_events()
                pose = station.poll_state().get(Topic.POSE)
                if isinstance(pose, PoseMsg):
                    poses.append(pose)
                states.update(control.poll_states())
                if not states["replay1"].playing and states["replay1"].position > 1.0:
                    break
                time.sleep(0.01)
            final = states["replay1"]
            assert final.position == pytest.approx(final.duration)  # played to the end at x20
            assert isinstance(
                query_state(station, "replay1").get(Topic.MAP), OccupancyGrid
            )  # answered
            assert len(poses) >= 5 and any(p.state == "ok" for p in poses)
            stamps = [p.stamp for p in poses]
            assert stamps == sorted(stamps)
            control.send("replay1", ReplayCommand("seek", 2.0))
            while time.monotonic() < deadline + 20.0:
                states.update(control.poll_states())
                if states["replay1"].position == pytest.approx(2.0):
                    break
                time.sleep(0.01)
            assert states["replay1"].position == pytest.approx(2.0)
            control.close()
            station.close()
    finally:
        stop.set()
        thread.join(10.0)
    assert not thread.is_alive()
