"""Fixtures: a real daemon run recorded once per session (used by the readback and replay tests)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from interbot_core.topics import InitialPose, Lock, PoseMsg, RouteMsg, Topic
from interbot_link import StationLink, open_session
from robot_daemon.config import DaemonConfig, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.recording import daemon_hook
from robot_daemon.recording.daemon_hook import RecordingLink
from robot_daemon.systemd_notify import SystemdNotifier

ROBOT = "recbot"


def _free_endpoint() -> str:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def _wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.005)


def record_daemon_run(directory: Path, endpoint: str) -> Path:
    """Run the daemon with ``--record directory`` for a few seconds; the recording's path."""
    config = DaemonConfig(
        robot_id=ROBOT,
        sim=SimSettings(seed=3, people=0, realtime_factor=8.0),
        zenoh=ZenohSettings((endpoint,), ()),
        start_latched=False,  # the recording's own stop is the one under test
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
                _wait_until(lambda: ROBOT in station.robots, 10.0, "the robot")
                station.select_robot(ROBOT)
                home = daemon.start_pose
                station.send(Topic.INITIAL_POSE, InitialPose(home.x, home.y, home.yaw))

                def localised() -> bool:
                    pose = station.poll_state().get(Topic.POSE)
                    return isinstance(pose, PoseMsg) and pose.state == "ok"

                _wait_until(localised, 10.0, "localised")
                assert daemon.topo is not None
                node = daemon.topo.node(1).pose
                station.send(Topic.ROUTE, RouteMsg(5, ((node.x, node.y, node.yaw),), (1,)))
                _wait_until(lambda: daemon.now > 6.0, 20.0, "6 s of robot time")
                station.send(Topic.STOP, Lock(True))
                _wait_until(lambda: daemon.stack.last_output.active_locks, 10.0, "the stop")
                station.close()
        finally:
            stop.set()
            thread.join(10.0)
            link.close()
            recorder.close()
    assert recorder.dropped == 0 and recorder.errors == 0
    (path,) = recorder.files
    return path


@pytest.fixture(scope="session")
def daemon_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recording of ~7 s of robot time: localised, a route, an emergency stop."""
    return record_daemon_run(tmp_path_factory.mktemp("daemon_rec"), _free_endpoint())
