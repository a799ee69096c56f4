"""The daemon records what it publishes and what the station commands (RecordingLink).

The daemon runs in a thread on simulated time (8x); a station on loopback localises it, sends
a route and an emergency stop (conftest.py: ``daemon_recording``); the recording is then read
back with the `mcap` package.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

ROBOT = "recbot"
pytestmark = pytest.mark.timeout(120)


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
