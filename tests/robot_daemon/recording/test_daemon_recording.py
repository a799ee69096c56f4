"""The daemon records what it publishes and what the station commands (RecordingLink).

The daemon runs in a thread on simulated time (8x); a station on loopback localises it, sends
a route and an emergency stop; the recording is then read back with the `mcap` package.
"""

from __future__ import annotations

import json
import threading
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from interbot_core.topics import InitialPose, Lock, PoseMsg, RouteMsg, Topic
from interbot_link import StationLink, open_session
from robot_daemon.config import DaemonConfig, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.recording import daemon_hook
from robot_daemon.recording.daemon_hook import RecordingLink
from robot_daemon.systemd_notify import SystemdNotifier

ROBOT = "recbot"
pytestmark = pytest.mark.timeout(120)


def record_daemon_run(directory: Path, endpoint: str, wait_until: Callable[..., None]) -> Path:
    """Run the daemon with ``--record directory`` for a few seconds; the recording's path."""
    config = DaemonConfig(
        robot_id=ROBOT,
        sim=SimSettings(seed=3, people=0, realtime_factor=8.0),
        zenoh=ZenohSettings((endpoint,), ()),
    )
    options = DaemonOptions(record_dir=directory)
    daemon = Daemon(config, options)
    recorder = daemon_hook.build_daemon_recorder(config, options, daemon.now)
    assert recorder is not None
    stop = threading.Event()
    with open_session([endpoint], []) as robot_session:
        link = daemon_hook.make_link(robot_session, daemon, recorder)
        assert isinstance(link, RecordingLink)
        thread = threading.Thread(
            target=daemon.run, args=(link, stop, SystemdNotifier({})), daemon=True
        )
        thread.start()
        try:
            with open_session([], [endpoint]) as station_session:
                station = StationLink(station_session)
                wait_until(lambda: ROBOT in station.robots, 10.0, "the robot")
                station.select_robot(ROBOT)
                home = daemon.start_pose
                station.send_initial_pose(InitialPose(home.x, home.y, home.yaw))

                def localised() -> bool:
                    pose = station.poll_state().get(Topic.POSE)
                    return isinstance(pose, PoseMsg) and pose.state == "ok"

                wait_until(localised, 10.0, "localised")
                assert daemon.topo is not None
                node = daemon.topo.node(1).pose
                station.send_route(RouteMsg(5, ((node.x, node.y, node.yaw),), (1,)))
                wait_until(lambda: daemon.now > 6.0, 20.0, "6 s of robot time")
                station.send_stop(Lock(True))
                wait_until(lambda: daemon.stack.last_output.active_locks, 10.0, "the stop")
                station.close()
        finally:
            stop.set()
            thread.join(10.0)
            link.close()
            recorder.close()
    assert recorder.dropped == 0 and recorder.errors == 0
    (path,) = recorder.files
    return path


def _read(path: Path) -> tuple[Counter[str], dict[str, str], list[dict[str, Any]]]:
    counts: Counter[str] = Counter()
    schemas: dict[str, str] = {}
    commands = []
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            counts[channel.topic] += 1
            schemas[channel.topic] = schema.name if schema else ""
            if channel.topic == "/commands":
                commands.append(json.loads(message.data))
    return counts, schemas, commands


def test_the_daemon_records_its_state_and_the_stations_commands(daemon_recording: Path) -> None:
    assert daemon_recording.name.startswith(f"{ROBOT}_") and daemon_recording.suffix == ".mcap"
    counts, schemas, commands = _read(daemon_recording)
    for topic, schema in {
        "/map": "foxglove.Grid",
        "/scan": "foxglove.LaserScan",
        "/tf": "foxglove.FrameTransforms",
        "/route": "foxglove.PosesInFrame",
        "/planned_path": "foxglove.PosesInFrame",
        "/camera/image/compressed": "foxglove.CompressedImage",
        "/pose": "PoseMsg",
        "/odom": "Odom",
        "/cmd_vel": "Twist",
        "/mux": "MuxMsg",
        "/battery": "Battery",
        "/route_progress": "RouteProgress",
        "/plan": "PlanMsg",
        "/localisation": "interbotLocalisation",
        "/commands": "interbotCommands",
    }.items():
        assert schemas.get(topic) == schema, topic
    assert [c["topic"] for c in commands] == ["initial_pose", "route", "stop"]
    assert all(c["source"] == "station" for c in commands)
    assert commands[1]["message"]["route_id"] == 5
    # At 8x real time the daemon publishes once per loop pass at most (50 Hz of wall time),
    # so the counts follow the passes, not the nominal rates; odometry and poses go together.
    assert counts["/pose"] == counts["/odom"] == counts["/cmd_vel"] >= 20
    assert counts["/tf"] in (counts["/odom"], counts["/odom"] + 1)
    assert counts["/scan"] >= 20 and counts["/map"] >= 1
