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


def test_localisation_is_sampled_with_a_covariance_when_the_localiser_has_one(
    tmp_path: Path,
) -> None:
    import enum
    from dataclasses import dataclass
    from types import SimpleNamespace

    import numpy as np

    from interbot_core.geometry import Pose2D
    from robot_daemon.recording.daemon_hook import LOCALISATION, StackSampler
    from robot_daemon.recording.recorder import Recorder

    class State(enum.Enum):
        OK = "ok"

    @dataclass(frozen=True)
    class Estimate:  # a localiser that also estimates its covariance
        pose: Pose2D | None
        confidence: float
        covariance: np.ndarray

    path = tmp_path / "loc.mcap"
    with Recorder("r1", single_file=path) as recorder:
        stack = SimpleNamespace(last_estimate=None, localisation_state=State.OK)
        sampler = StackSampler(stack, recorder)  # type: ignore[arg-type]
        sampler.sample(0.0)  # no estimate yet: nothing
        stack.last_estimate = Estimate(Pose2D(1.0, 2.0, 0.5), 0.9, np.diag([0.01, 0.02, 0.003]))
        sampler.sample(0.1)
        sampler.sample(0.15)  # the same estimate: not again
    with path.open("rb") as f:
        records = [json.loads(m.data) for _, c, m in make_reader(f).iter_messages([LOCALISATION])]
    assert len(records) == 1
    assert records[0]["state"] == "ok" and records[0]["x"] == 1.0
    assert records[0]["covariance"] == pytest.approx([0.01, 0, 0, 0, 0.02, 0, 0, 0, 0.003])
