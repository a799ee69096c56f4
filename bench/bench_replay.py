"""Benchmark: a recording replayed at ×20 into the Base Station, every map update received?

The recording (written with the `Recorder`) is the issue's target load made harder for the map:
the laser at 40 Hz (1081 beams), the camera at 10 Hz (simulator JPEGs), pose / odometry /
cmd_vel at 20 Hz, the mux at 5 Hz, and a changed map (the ISR floor, 784k cells) every 30 s of
recording as the daemon republishes it (``BENCH_REPLAY_MAP_PERIOD=5`` for a map every 5 s: at
×20 that is 4 maps per second on the link).

`interbot replay FILE --speed 20 --paused` runs in its own process (as it would beside a
station); the Base Station runs in this one, `StationController` + `MainWindow` offscreen with
the Qt event loop and its timers, as in bench_teleop. Once the station shows the replay it
presses play through replay control and counts, until the replay reaches its end:

* ``replay_speed_x``: recording time over wall time, from the first and last pose the station
  received (their stamps are recording time), i.e. the speed the station actually saw;
* ``replay_maps_sent`` / ``replay_maps_received``: map messages in the file (after the first)
  / map updates the station applied (``RobotState.map_version``); ``replay_map_drops`` the
  difference (target 0);
* ``replay_poses_received``: poses the station applied (latest-only: some are coalesced by its
  25 ms frame timer, by design).

    .venv/bin/interbot bench --only replay --json
"""

from __future__ import annotations

import importlib.util
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

ROBOT = "replaybench"
SPEED = 20.0
DATA_S = 120.0
QUICK_DATA_S = 10.0
# The daemon republishes its map every 30 s (MAP_REPUBLISH_PERIOD); BENCH_REPLAY_MAP_PERIOD=5
# makes the map six times busier (4 maps per second on the link at x20).
MAP_PERIOD_S = float(os.environ.get("BENCH_REPLAY_MAP_PERIOD", "30.0"))


class BenchReplayError(RuntimeError):
    """The replay rig did not come up or finish (the message says which part)."""


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def write_recording(path: Path, seconds: float) -> int:
    """A recording of ``seconds``; the number of map messages in it."""
    from interbot_core.laser_scan import LaserScan
    from interbot_core.occupancy_grid import load_map
    from interbot_core.topics import ImageMsg, MuxMsg, Odom, PoseMsg, Topic, Twist
    from robot_daemon.recording.recorder import Recorder
    from robot_daemon.sim.camera_sim import encode_jpeg
    from robot_daemon.sim.simulator import SimConfig, Simulator

    grid = load_map(common.ISR_MAP)
    sim = Simulator(grid, SimConfig(n_people=0), rng_seed=1)
    frames = []
    for i in range(8):  # a few distinct camera frames, turning on the spot
        sim.set_cmd_vel(0.0, 1.0)
        sim.step(0.1 * (i + 1))
        frames.append(encode_jpeg(sim.camera_frame(), 70))
    rng = np.random.default_rng(4)
    maps = 0
    with Recorder(ROBOT, single_file=path, queue_size=1_000_000) as recorder:
        for i in range(int(seconds * 40)):
            t = i / 40.0
            ranges = rng.uniform(0.5, 12.0, 1081).astype(np.float32)
            recorder.state(Topic.SCAN, LaserScan(t, -2.356, 0.004363, 0.02, 30.0, ranges), t)
            if i % 2 == 0:
                x = 1.0 + 0.3 * t
                recorder.state(Topic.POSE, PoseMsg(x, 0.5, 0.0, t, "ok", 0.9), t)
                recorder.state(Topic.ODOM, Odom(x, 0.5, 0.0, 0.3, 0.0, t), t)
                recorder.state(Topic.CMD_VEL, Twist(0.3, 0.0, t), t)
            if i % 4 == 0:
                recorder.state(Topic.IMAGE, ImageMsg(t, 320, 240, frames[(i // 4) % 8]), t)
            if i % 8 == 0:
                recorder.state(Topic.MUX, MuxMsg("planner_vel", "", (), 0.3, 0.0, t), t)
            if i % int(MAP_PERIOD_S * 40) == 0:
                cells = grid.cells.copy()
                cells[100:110, 100 + maps : 110 + maps] = 100  # a changed map every time
                recorder.state(Topic.MAP, grid.with_cells(cells), t)
                maps += 1
    return maps


def run(quick: bool = False) -> dict[str, Any]:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    seconds = QUICK_DATA_S if quick else DATA_S
    with common.quiet_logs(), tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp:
        path = Path(tmp) / "replay.mcap"
        maps = write_recording(path, seconds)
        endpoint = f"tcp/127.0.0.1:{_free_port()}"
        cmd = [sys.executable, "-m", "interbot_cli.main", "replay", str(path)]
        cmd += ["--listen", endpoint, "--speed", str(SPEED), "--paused", "--robot-id", ROBOT]
        log = Path(tmp) / "replay.log"
        with log.open("w") as out:
            proc = subprocess.Popen(cmd, cwd=common.REPO, stdout=out, stderr=subprocess.STDOUT)
        try:
            return _measure(Path(tmp), endpoint, proc, log, maps, seconds)
        finally:
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(15.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


def _measure(
    tmp: Path, endpoint: str, proc: subprocess.Popen[bytes], log: Path, maps: int, seconds: float
) -> dict[str, Any]:
    import zenoh
    from PySide6.QtCore import QEventLoop, QSettings, QTimer
    from PySide6.QtWidgets import QApplication

    from base_station_app.main_window import MainWindow
    from base_station_app.station_controller import StationController
    from interbot_core.replay_control import ReplayCommand
    from interbot_core.topics import PoseMsg
    from interbot_core.topological_map import load_topological_map
    from interbot_link import session_config
    from interbot_link.replay import ReplayControlClient

    app = QApplication.instance() or QApplication([sys.argv[0]])
    loop = QEventLoop()

    def wait_until(done: Callable[[], bool], timeout_s: float, what: str) -> None:
        deadline = time.perf_counter() + timeout_s
        timer = QTimer()
        timer.setInterval(5)
        timer.timeout.connect(lambda: (done() or time.perf_counter() > deadline) and loop.quit())
        timer.start()
        if not done():
            loop.exec()
        timer.stop()
        if not done():
            tail = log.read_text(encoding="utf-8")[-1500:]
            raise BenchReplayError(
                f"bench_replay: timed out waiting for {what}; replay log: {tail}"
            )

    session = zenoh.open(session_config([], [endpoint]))
    controller = StationController(
        load_topological_map(common.ISR_TOPO), session, topo_path=common.ISR_TOPO,
        tablet_port=0, robot_id=ROBOT,
    )  # fmt: skip
    window = MainWindow(controller, QSettings(str(tmp / "station.ini"), QSettings.Format.IniFormat))
    client = ReplayControlClient(session)
    poses: list[tuple[float, float]] = []  # (wall time, pose stamp)

    def on_frame() -> None:
        pose = controller.selected.state.pose
        if isinstance(pose, PoseMsg) and (not poses or pose.stamp != poses[-1][1]):
            poses.append((time.perf_counter(), pose.stamp))

    try:
        controller.start()
        window.resize(1600, 1000)
        window.show()
        bar = window.replay_bar
        wait_until(lambda: bar.replay_state is not None and controller.selected.state.grid is not None, 60.0, "the replay in the station")  # fmt: skip
        first_version = controller.selected.state.map_version
        controller.frame_ready.connect(on_frame)
        client.send(ROBOT, ReplayCommand("play"))
        wait_until(
            lambda: bar.replay_state is not None and bar.replay_state.position >= bar.replay_state.duration - 1e-6,
            seconds / SPEED * 5 + 30.0, "the replay's end",
        )  # fmt: skip
        end = time.perf_counter() + 1.0  # let the last messages arrive
        while time.perf_counter() < end:
            app.processEvents()
            time.sleep(0.005)
        received = controller.selected.state.map_version - first_version
        moving = [(w, s) for w, s in poses if s > 0.0]
        speed = (
            (moving[-1][1] - moving[0][1]) / (moving[-1][0] - moving[0][0])
            if len(moving) > 1
            else 0.0
        )
        return {
            "replay_speed_x": speed,
            "replay_maps_sent": maps - 1,  # the first was shown before play was pressed
            "replay_maps_received": received,
            "replay_map_drops": max(0, maps - 1 - received),
            "replay_poses_received": len(poses),
            "replay_data_s": seconds,
        }
    finally:
        window.close()
        controller.shutdown()
        client.close()
        session.close()


if __name__ == "__main__":
    import json

    print(json.dumps(run(quick="--quick" in sys.argv), indent=1))
