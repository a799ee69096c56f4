"""Screenshots of the Base Station: runs it offscreen against a fake robot and grabs each tab.

The fake robot is a `RobotLink` on a loopback zenoh session that publishes the ISR floor-0 map,
a pose moving along the station's route, a laser scan ray-cast on the map, battery, multiplexer
state and a camera frame; a raw-socket tablet says hello, answers pings and sends joystick
commands. Writes ``docs/screenshots/station_<tab>.png`` (window 1600 x 1000). Run:
``QT_QPA_PLATFORM=offscreen .venv/bin/python tools/make_screenshots_station.py``.
"""

from __future__ import annotations

import json
import logging
import math
import os
import socket
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np
import zenoh
from PySide6.QtCore import QBuffer, QByteArray, QIODevice, QSettings, Qt
from PySide6.QtGui import QColor, QFont, QImage, QPainter
from PySide6.QtWidgets import QApplication

from base_station_app.main_window import TAB_NAMES, MainWindow
from base_station_app.station_controller import StationController
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.supervisor import Delivery, GoTo, GuidedTour
from interbot_core.topics import Battery, ImageMsg, MuxMsg, Odom, PoseMsg
from interbot_core.topological_map import load_topological_map
from interbot_link import RobotLink, session_config

logger = logging.getLogger(__name__)

REPO = Path(__file__).resolve().parent.parent
TOPO = REPO / "maps" / "isr_floor0_topo.yaml"
OUT = REPO / "docs" / "screenshots"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def ray_cast(grid: OccupancyGrid, pose: Pose2D, n: int = 541, max_range: float = 30.0) -> LaserScan:
    """A 270-degree scan of ``grid`` from ``pose`` by marching every beam in 2.5 cm steps."""
    angles = np.linspace(-3 * math.pi / 4, 3 * math.pi / 4, n)
    steps = np.arange(0.1, max_range, grid.resolution / 2)
    a = angles[:, None] + pose.yaw
    xs = pose.x + steps[None, :] * np.cos(a)
    ys = pose.y + steps[None, :] * np.sin(a)
    cols = ((xs - grid.origin_x) / grid.resolution).astype(int)
    rows = ((ys - grid.origin_y) / grid.resolution).astype(int)
    inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
    hit = np.zeros_like(inside)
    hit[inside] = grid.cells[rows[inside], cols[inside]] == 100
    first = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
    ranges = np.where(first >= 0, steps[np.maximum(first, 0)], np.nan).astype(np.float32)
    return LaserScan(
        time.monotonic(), -3 * math.pi / 4, 1.5 * math.pi / (n - 1), 0.1, max_range, ranges
    )


def camera_jpeg(text: str) -> bytes:
    image = QImage(640, 360, QImage.Format.Format_RGB32)
    image.fill(QColor(70, 90, 110))
    painter = QPainter(image)
    painter.fillRect(0, 250, 640, 110, QColor(150, 140, 120))
    painter.fillRect(260, 90, 120, 160, QColor(120, 80, 50))
    painter.setPen(QColor(255, 255, 255))
    painter.setFont(QFont("Sans", 20))
    painter.drawText(image.rect(), Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft, text)
    painter.end()
    data = QByteArray()
    buffer = QBuffer(data)
    buffer.open(QIODevice.OpenModeFlag.WriteOnly)
    image.save(buffer, "JPG", 85)
    return bytes(data.data())


class Tablet:
    """A raw-socket tablet that answers the station's pings at once."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.sock.setblocking(False)
        self.buffer = b""
        self.send({"hello": {"protocol": 1, "client": "screenshot tablet"}})

    def send(self, obj: dict[str, object]) -> None:
        self.sock.sendall(json.dumps(obj).encode())

    def serve(self) -> None:
        try:
            self.buffer += self.sock.recv(65536)
        except BlockingIOError:
            return
        *lines, self.buffer = self.buffer.split(b"\n")
        for line in lines:
            msg = json.loads(line)
            if "ping" in msg:
                self.send({"pong": msg["ping"]})


TABLET: Tablet | None = None


def pump(app: QApplication, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        if TABLET is not None:
            TABLET.serve()
        time.sleep(0.002)


def main() -> int:
    logging.basicConfig(level=logging.WARNING)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    topo = load_topological_map(TOPO)
    grid = load_map(topo.map_yaml_path)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    robot_session = zenoh.open(session_config([endpoint], []))
    station_session = zenoh.open(session_config([], [endpoint]))
    robot = RobotLink(robot_session, "interbot1")
    settings_dir = tempfile.TemporaryDirectory()
    settings = QSettings(str(Path(settings_dir.name) / "station.ini"), QSettings.Format.IniFormat)
    controller = StationController(topo, station_session, topo_path=TOPO, tablet_port=0)
    window = MainWindow(controller, settings)
    window.resize(1600, 1000)
    window.show()
    controller.start()
    tablet = None
    try:
        robot.publish_map(grid)
        pose = topo.nodes[0].pose
        pose = Pose2D(pose.x + 1.0, pose.y - 1.5, -math.pi / 2)

        def publish(p: Pose2D, v: float = 0.0, w: float = 0.0) -> None:
            robot.publish_pose(PoseMsg(p.x, p.y, p.yaw, stamp=time.monotonic(), confidence=0.93))
            robot.publish_odom(Odom(p.x, p.y, p.yaw, v, w, stamp=time.monotonic()))
            robot.publish_scan(ray_cast(grid, p))

        publish(pose)
        robot.publish_battery(Battery(25.1, 3.2, 0.82))
        robot.publish_mux(MuxMsg("planner_vel", "highest valid input", (), 0.4, 0.1))
        robot.publish_image(ImageMsg(time.monotonic(), 640, 360, camera_jpeg("camera: corridor")))
        deadline = time.monotonic() + 5
        while controller.selected_robot != "interbot1" and time.monotonic() < deadline:
            pump(app, 0.05)
        pump(app, 0.3)
        robot.publish_map(grid)

        global TABLET
        tablet = TABLET = Tablet(controller.tablet.port)
        controller.submit(GoTo(9))
        controller.submit(GuidedTour())
        controller.submit(Delivery("the blue folder", 7, 0))
        pump(app, 0.3)
        route = controller.route
        steps = 60
        if route is not None:
            target = route.waypoints[1] if len(route.waypoints) > 1 else route.waypoints[0]
            for k in range(steps):
                f = (k + 1) / steps * 0.9
                first = route.waypoints[0]
                x = pose.x + (first[0] - pose.x) * min(1.0, 2 * f)
                y = pose.y + (first[1] - pose.y) * min(1.0, 2 * f)
                if f > 0.5:
                    x = first[0] + (target[0] - first[0]) * (2 * f - 1)
                    y = first[1] + (target[1] - first[1]) * (2 * f - 1)
                yaw = math.atan2(target[1] - y, target[0] - x)
                publish(Pose2D(x, y, yaw), 0.45, 0.05)
                if k % 5 == 0:
                    robot.publish_image(
                        ImageMsg(time.monotonic(), 640, 360, camera_jpeg(f"camera: corridor {k}"))
                    )
                tablet.send({"speed": {"linear": 0.2, "angular": 0.1}})
                pump(app, 0.1 if k % 10 else 0.25)
        controller.permissions = controller.permissions.with_kind("requests", False)
        controller.tablet_changed.emit()
        OUT.mkdir(parents=True, exist_ok=True)
        for index, name in enumerate(TAB_NAMES):
            window.tabs.setCurrentIndex(index)
            if name == "diagnostics":
                window.diagnostics_panel.redraw()
            pump(app, 0.3)
            path = OUT / f"station_{name}.png"
            window.grab().save(str(path))
            sys.stdout.write(f"wrote {path.relative_to(REPO)}\n")
    finally:
        if tablet is not None:
            tablet.sock.close()
        window.close()
        controller.shutdown()
        robot.close()
        station_session.close()
        robot_session.close()
        settings_dir.cleanup()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
