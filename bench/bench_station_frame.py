"""Benchmark: the Base Station's cost of one displayed frame on its Qt thread (issue 14).

The station's Qt thread forwards the tablet's commands and also draws; a command that arrives
during a frame waits for it. This measures that frame: `QtMapView.redraw()` (scan placed from
its pose, robot, route) plus a synchronous repaint of the map view, in the real `MainWindow`
(1600 x 1000, offscreen), on the ISR map, with a 1081-beam scan and a new pose each frame.

Figures are the Qt thread's **CPU time** (``time.thread_time``), so they change little with the
load of other processes; ``station_frame_wall_ms_*`` is the wall time beside it (it does).

    .venv/bin/interbot bench --only station_frame --json
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

FRAMES = 300
QUICK_FRAMES = 30
WARMUP = 10
BEAMS = 1081


def run(quick: bool = False) -> dict[str, Any]:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    with common.quiet_logs(), tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp:
        return _measure(Path(tmp), QUICK_FRAMES if quick else FRAMES)


def _measure(tmp: Path, frames: int) -> dict[str, Any]:
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from base_station_app.main_window import MainWindow
    from base_station_app.station_controller import StationController
    from interbot_core.laser_scan import LaserScan
    from interbot_core.topics import PoseMsg, Topic
    from interbot_core.topological_map import load_topological_map

    app = QApplication.instance() or QApplication([sys.argv[0]])
    topo = load_topological_map(common.ISR_TOPO)
    controller = StationController(topo, None, topo_path=common.ISR_TOPO, tablet_port=0)
    window = MainWindow(controller, QSettings(str(tmp / "s.ini"), QSettings.Format.IniFormat))
    try:
        window.resize(1600, 1000)
        window.show()
        app.processEvents()
        view = window.map_view
        view.fit_map()
        app.processEvents()
        home = topo.nodes[0].pose
        ranges = np.full(BEAMS, 5.0, dtype=np.float32)
        step = 1.5 * math.pi / (BEAMS - 1)
        cpu, wall = [], []
        for i in range(WARMUP + frames):
            stamp = 10.0 + 0.05 * i
            yaw = math.remainder(0.01 * i, 2 * math.pi)
            controller.selected.state.apply(Topic.POSE, PoseMsg(home.x, home.y, yaw, stamp=stamp))
            scan = LaserScan(stamp, -0.75 * math.pi, step, 0.1, 30.0, ranges)
            controller.selected.state.apply(Topic.SCAN, scan)
            c0, w0 = time.thread_time(), time.perf_counter()
            view.redraw()
            view.viewport().repaint()
            c1, w1 = time.thread_time(), time.perf_counter()
            if i >= WARMUP:
                cpu.append(c1 - c0)
                wall.append(w1 - w0)
        points = float(len(view.scan_item.getData()[0]))
    finally:
        window.close()
        controller.shutdown()
        app.processEvents()
    out: dict[str, Any] = {}
    out.update(common.summary_ms(cpu, "station_frame_cpu"))
    out.update(common.summary_ms(wall, "station_frame_wall"))
    out["station_frame_scan_points"] = points
    out["station_frames"] = float(len(cpu))
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
