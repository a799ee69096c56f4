"""Screenshot of the Base Station watching a replay (``docs/screenshots/station_replay.png``).

Records 90 s of the simulated guided tour (`ScenarioRecorder`, as ``interbot scenario tour
--record``), plays it with `serve_replay` on a loopback zenoh session at x5, lets the offscreen
station (window 1600 x 1000) follow it for a moment, pauses and grabs the window: the replay bar
is under the map. Run:
``QT_QPA_PLATFORM=offscreen .venv/bin/python tools/make_screenshot_replay.py``.
"""

from __future__ import annotations

import logging
import os
import socket
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import zenoh
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication

from base_station_app.main_window import MainWindow
from base_station_app.station_controller import StationController
from interbot_core.replay_control import ReplayCommand
from interbot_core.supervisor import GuidedTour
from interbot_core.topological_map import load_topological_map
from interbot_link import session_config
from interbot_link.replay import ReplayControlClient
from robot_daemon.recording.replay import serve_replay
from robot_daemon.recording.scenario_recording import ScenarioRecorder
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour

REPO = Path(__file__).resolve().parent.parent
TOPO = REPO / "maps" / "isr_floor0_topo.yaml"
OUT = REPO / "docs" / "screenshots" / "station_replay.png"


def record_tour(path: Path, seconds: float) -> None:
    with ScenarioRecorder(path, epoch_offset=time.time(), robot_id="interbot1") as recorder:
        system = SimulatedSystem(replace(ScenarioOptions(people=4), recorder=recorder))
        system.hooks.append(auto_resume_tour(5.0))
        system.localise()
        system.apply(system.supervisor.submit(GuidedTour()))
        system.run_until(lambda: False, max_time=seconds)


def pump(app: QApplication, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.005)


def main() -> int:
    logging.basicConfig(level=logging.WARNING)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    with tempfile.TemporaryDirectory() as tmp:
        recording = Path(tmp) / "interbot1_tour.mcap"
        record_tour(recording, 90.0)
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            endpoint = f"tcp/127.0.0.1:{s.getsockname()[1]}"
        stop = threading.Event()
        ready = threading.Event()
        replay = threading.Thread(
            target=serve_replay,
            args=(recording, [endpoint], [], stop),
            kwargs={"speed": 5.0, "paused": True, "ready": lambda _: ready.set()},
            daemon=True,
        )
        replay.start()
        ready.wait(30.0)
        session = zenoh.open(session_config([], [endpoint]))
        settings = QSettings(str(Path(tmp) / "station.ini"), QSettings.Format.IniFormat)
        controller = StationController(
            load_topological_map(TOPO), session, topo_path=TOPO, tablet_port=0
        )
        window = MainWindow(controller, settings)
        window.resize(1600, 1000)
        window.show()
        controller.start()
        client = ReplayControlClient(session)
        try:
            deadline = time.monotonic() + 20.0
            while window.replay_bar.isHidden() and time.monotonic() < deadline:
                pump(app, 0.1)
            client.send("interbot1", ReplayCommand("seek", 40.0))
            client.send("interbot1", ReplayCommand("play"))
            pump(app, 4.0)  # 20 s of the tour at x5
            client.send("interbot1", ReplayCommand("pause"))
            pump(app, 1.0)
            OUT.parent.mkdir(parents=True, exist_ok=True)
            window.grab().save(str(OUT))
            print(f"wrote {OUT}")
        finally:
            client.close()
            window.close()
            controller.shutdown()
            stop.set()
            replay.join(10.0)
            session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
