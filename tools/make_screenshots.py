"""Screenshots of the real programs: the simulated robot daemon, the Base Station and the Tablet.

    QT_QPA_PLATFORM=offscreen .venv/bin/python tools/make_screenshots.py [--out DIR] [--speed X]

Nothing is staged. The robot daemon runs as its own process (the simulator, on loopback zenoh,
with people walking about); the Base Station (`StationController` + `MainWindow`) and the Tablet
(`TabletConnection` + `TabletWindow`) run in this process on the offscreen platform, the tablet
connected to the station's real tablet server. The script then uses the programs as a person
would, by clicking their buttons, and grabs each state:

1. the robot does not know where it is: the tablet asks for help; the station shows it unset;
2. "Help me!" on the tablet, then the room it is at: the robot is localised;
3. the tablet's menu, joystick, room and request dialogs (with the on-screen keyboard) and
   malfunction report, at 1280 x 800 (149 dpi) and 2560 x 1600 (299 dpi);
4. "Take me there": the robot drives; the tablet's motion bar, the station's map with the scan,
   the planned path and the camera, and every station tab;
5. a guided tour to its first stop: the tour dialog on the tablet;
6. the same tablet screens in Portuguese;
7. a fleet (issue 14): ``interbot router``, five simulated robot daemons as its clients and a
   fresh station with no ``--robot`` and no saved choice: the station asks which robot to command
   (``station_fleet_choice``); a click answers; three robots are given tasks by clicking their
   rows in the robot list, one robot is left unlocalised and one is stopped (it goes offline):
   the map shows every robot with its name, state colour and planned path (``station_fleet``).

``--only fleet`` takes step 7 alone. Writes ``docs/screenshots/station_<tab>.png``,
``station_fleet*.png`` and ``tablet_<screen>_<w>x<h>.png``.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from contextlib import closing
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import zenoh
from PySide6.QtCore import QPoint, QSettings, Qt
from PySide6.QtGui import QPainter, QPixmap
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QWidget

from base_station_app.main_window import TAB_NAMES, MainWindow
from base_station_app.station_controller import StationController
from interbot_core.supervisor import GoTo
from interbot_core.topological_map import load_topological_map
from interbot_link import StationLink, session_config
from tablet_app.main import load_plan
from tablet_app.main_window import TabletWindow
from tablet_app.tablet_connection import TabletConnection

logger = logging.getLogger("make_screenshots")

REPO = Path(__file__).resolve().parent.parent
TOPO = REPO / "maps" / "isr_floor0_topo.yaml"
TABLETS = ((1280, 800, 149.0), (2560, 1600, 299.0))
START_NODE = 0  # Main Entrance
GOAL_ROOM = 3  # Restrooms, across the corridor


class Programs:
    """The daemon process, the station and the tablet, and a way to wait on them."""

    def __init__(self, speed: float) -> None:
        self.app = QApplication.instance() or QApplication(sys.argv[:1])
        port = _free_port()
        endpoint = f"tcp/127.0.0.1:{port}"
        self.daemon = subprocess.Popen(
            [
                sys.executable, "-m", "robot_daemon.main", "--sim", "--robot-id", "interbot1",
                "--listen", endpoint, "--seed", "1", "--people", "3", "--speed", str(speed),
                "--start-node", str(START_NODE),
                "--no-relocalise",  # the screenshots show a person's "Help me!" flow
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )  # fmt: skip
        self.session = zenoh.open(session_config([], [endpoint]))
        self._settings_dir = tempfile.TemporaryDirectory()
        settings = QSettings(
            str(Path(self._settings_dir.name) / "station.ini"), QSettings.Format.IniFormat
        )
        topo = load_topological_map(TOPO)
        self.station = StationController(
            topo, self.session, topo_path=TOPO, tablet_port=0, robot_id="interbot1"
        )
        self.station_window = MainWindow(self.station, settings)
        self.station_window.resize(1600, 1000)
        self.station_window.show()
        assert self.station.start(), "the station did not start"
        plan, grid = load_plan(TOPO)
        self.connection = TabletConnection("127.0.0.1", self.station.tablet.port)
        self.tablet = TabletWindow(self.connection, plan, grid)
        self.tablet.resize(1280, 800)
        self.tablet.show()
        self.connection.start()

    def wait(self, condition: Callable[[], bool], timeout: float, what: str) -> None:
        end = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > end:
                raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
            QTest.qWait(20)

    def close(self) -> None:
        self.connection.stop()
        self.tablet.close()
        self.station_window.close()
        self.station.shutdown()
        self.session.close()
        self.daemon.send_signal(signal.SIGTERM)
        try:
            self.daemon.wait(10)
        except subprocess.TimeoutExpired:
            self.daemon.kill()
        self._settings_dir.cleanup()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def click(widget: QWidget) -> None:
    QTest.mouseClick(widget, Qt.MouseButton.LeftButton)


def grab_with_dialog(window: TabletWindow) -> QPixmap:
    """The window, with its open dialog drawn where it sits on screen (dialogs are windows)."""
    QTest.qWait(120)
    shot = window.grab()
    dialog = window.dialog
    if dialog is not None and dialog.isVisible():
        painter = QPainter(shot)
        painter.fillRect(shot.rect(), Qt.GlobalColor.transparent)
        painter.setOpacity(0.45)
        painter.fillRect(shot.rect(), Qt.GlobalColor.black)
        painter.setOpacity(1.0)
        top_left = QPoint(
            (shot.width() - dialog.width()) // 2, (shot.height() - dialog.height()) // 2
        )
        painter.drawPixmap(top_left, dialog.grab())
        painter.end()
    return shot


def save(pixmap: QPixmap, out: Path, name: str) -> None:
    path = out / f"{name}.png"
    pixmap.save(str(path))
    sys.stdout.write(f"wrote {path.relative_to(REPO) if path.is_relative_to(REPO) else path}\n")


def help_me(p: Programs, room: int) -> None:
    """ "Help me!" on the tablet, then the room the robot is at, until the robot confirms."""
    t, s = p.tablet, p.station
    t.show_map()
    p.wait(lambda: t.map_screen.help_button.isVisible(), 15, "the Help me! button")
    click(t.map_screen.help_button)
    click(t.map_view.room_button(room))
    click(t.dialog.yes_button)  # type: ignore[union-attr]
    p.wait(lambda: s.selected.state.localisation == "ok", 30, "the robot to be localised")
    p.wait(lambda: not t.session.lost, 10, "the tablet to know")


def tablet_screens(p: Programs, out: Path, suffix: str) -> None:
    """Menu, joystick, map, room and request dialogs, malfunction report at every size."""
    t = p.tablet
    for width, height, dpi in TABLETS:
        t.dpi_override = dpi
        t.resize(width, height)
        t.apply_metrics()
        size = f"{width}x{height}{suffix}"
        t.show_menu()
        save(grab_with_dialog(t), out, f"tablet_menu_{size}")
        t.show_joystick()
        joystick = t.joystick_screen.joystick
        QTest.qWait(50)
        r = joystick.radius()
        at = joystick.center().toPoint() + QPoint(-round(r * 0.3), -round(r * 0.6))
        QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=at)
        save(grab_with_dialog(t), out, f"tablet_joystick_{size}")
        QTest.mouseRelease(joystick, Qt.MouseButton.LeftButton, pos=at)
        t.show_map()
        save(grab_with_dialog(t), out, f"tablet_map_{size}")
        request_room = next(r.id for r in t.shown_plan.rooms if r.requests)
        click(t.map_view.room_button(request_room))
        save(grab_with_dialog(t), out, f"tablet_room_dialog_{size}")
        click(t.dialog.request_button)  # type: ignore[union-attr]
        keys = t.dialog.keyboard.keys  # type: ignore[union-attr]
        for key in ("shift", "u", "m", "space", "c", "a", "f", "é"):
            click(keys[key])
        save(grab_with_dialog(t), out, f"tablet_request_dialog_{size}")
        t.dialog.close()  # type: ignore[union-attr]
        click(t.menu.malfunction_button)
        save(grab_with_dialog(t), out, f"tablet_malfunction_dialog_{size}")
        t.dialog.close()  # type: ignore[union-attr]
    t.dpi_override = TABLETS[0][2]
    t.resize(TABLETS[0][0], TABLETS[0][1])


FLEET = {  # robot id: (start node, localised at start)
    "fleet0": (0, True),
    "fleet1": (6, True),
    "fleet2": (12, True),
    "fleet3": (17, False),  # nobody told it where it is: drawn "lost" at its last pose
    "fleet4": (21, True),  # stopped (its process ends) after it was seen: "offline"
}
FLEET_GOALS = {"fleet0": 9, "fleet1": 14, "fleet2": 3}


def grab_window_with(window: QWidget, dialog: QWidget | None) -> QPixmap:
    """``window`` with ``dialog`` drawn centred over it, the window dimmed (as on screen)."""
    QTest.qWait(150)
    shot = window.grab()
    if dialog is not None and dialog.isVisible():
        painter = QPainter(shot)
        painter.setOpacity(0.35)
        painter.fillRect(shot.rect(), Qt.GlobalColor.black)
        painter.setOpacity(1.0)
        top_left = QPoint(
            (shot.width() - dialog.width()) // 2, (shot.height() - dialog.height()) // 2
        )
        painter.drawPixmap(top_left, dialog.grab())
        painter.end()
    return shot


def fleet_screenshots(out: Path, speed: float) -> None:
    """Step 7 (module docstring): five robots through the router, one station."""
    app = QApplication.instance() or QApplication(sys.argv[:1])
    assert app is not None
    router = f"tcp/127.0.0.1:{_free_port()}"
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "interbot_cli.main", "router", "--listen", router],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    for robot_id, (node, localised) in FLEET.items():
        command = [
            sys.executable, "-m", "robot_daemon.main", "--sim", "--robot-id", robot_id,
            "--mode", "client", "--connect", router, "--seed", "1", "--people", "0",
            "--speed", str(speed), "--start-node", str(node), "--no-relocalise",
        ]  # fmt: skip
        if localised:
            command.append("--auto-localise")
        procs.append(
            subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        )
    end = time.monotonic() + 30.0
    while True:  # the router process takes a moment to listen
        try:
            session = zenoh.open(session_config([], [router], "client"))
            break
        except zenoh.ZError:
            if time.monotonic() > end:
                raise
            time.sleep(0.3)
    with closing(StationLink(session)) as probe:  # a station (re)started while five robots run
        end = time.monotonic() + 90.0
        while len(probe.robots) < len(FLEET):  # the liveliness subscriber's view
            if time.monotonic() > end:
                raise TimeoutError("the five robots did not reach the router")
            time.sleep(0.5)
    settings_dir = tempfile.TemporaryDirectory()
    settings = QSettings(str(Path(settings_dir.name) / "s.ini"), QSettings.Format.IniFormat)
    station = StationController(load_topological_map(TOPO), session, topo_path=TOPO, tablet_port=0)
    window = MainWindow(station, settings)
    window.resize(1600, 1000)
    window.show()

    def wait(condition: Callable[[], bool], timeout: float, what: str) -> None:
        end = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > end:
                raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
            QTest.qWait(20)

    try:
        assert station.start()
        window.map_view.fit_map()
        wait(
            lambda: (
                window.robot_choice is not None and len(window.robot_choice.buttons) == len(FLEET)
            ),
            90,
            "the station to ask which of the five robots to command",
        )
        save(grab_window_with(window, window.robot_choice), out, "station_fleet_choice")
        click(window.robot_choice.buttons["fleet0"])  # type: ignore[union-attr]
        wait(lambda: station.selected_robot == "fleet0", 10, "fleet0 selected")
        for robot_id, goal in FLEET_GOALS.items():
            panel = window.robots_panel
            window.tabs.setCurrentWidget(panel)
            item = panel.row_of(robot_id)
            assert item is not None
            rect = panel.robot_list.visualItemRect(item)
            QTest.mouseClick(
                panel.robot_list.viewport(), Qt.MouseButton.LeftButton, pos=rect.center()
            )
            click(panel.select_button)
            wait(lambda r=robot_id: station.selected_robot == r, 10, f"{robot_id} selected")  # type: ignore[misc]
            wait(lambda: station.selected.state.localisation == "ok", 60, f"{robot_id} localised")
            station.submit(GoTo(goal))

        def planned() -> bool:
            views = {v.robot_id: v for v in station.fleet.views(station.names)}
            return all(views[r].plan for r in FLEET_GOALS if r != station.selected_robot)

        wait(planned, 60, "every robot's planned path")
        procs[-1].send_signal(signal.SIGTERM)  # fleet4 stops: drawn offline at its last pose
        wait(lambda: not station.robots.get("fleet4", True), 30, "fleet4 offline")
        QTest.qWait(int(20000 / max(speed, 0.5)))  # let the robots drive a while
        window.tabs.setCurrentWidget(window.robots_panel)
        save(grab_window_with(window, None), out, "station_fleet")
    finally:
        window.close()
        station.shutdown()
        session.close()
        for proc in reversed(procs):
            proc.send_signal(signal.SIGTERM)
        for proc in procs:
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
        settings_dir.cleanup()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "screenshots")
    parser.add_argument("--speed", type=float, default=2.0, help="simulated seconds per second")
    parser.add_argument("--only", choices=("fleet",), help="take only this step")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.only == "fleet":
        fleet_screenshots(args.out, args.speed)
        return 0
    p = Programs(args.speed)
    try:
        t, s, out = p.tablet, p.station, args.out
        p.wait(lambda: s.selected_robot == "interbot1", 20, "the station to see the robot")
        p.wait(lambda: s.tablet.is_connected, 10, "the tablet to connect")

        # 1. Not localised: the tablet asks for help.
        t.show_map()
        p.wait(lambda: t.help_button.isVisible() or t.session.lost, 15, "the tablet to be lost")
        for width, height, dpi in TABLETS:
            t.dpi_override = dpi
            t.resize(width, height)
            t.apply_metrics()
            save(grab_with_dialog(t), out, f"tablet_map_help_{width}x{height}")
        t.resize(1280, 800)
        t.apply_metrics()

        # 2. Help me!: choose the room the robot is at; the robot confirms.
        help_me(p, START_NODE)

        # 3. The tablet's screens, in English and in Portuguese.
        tablet_screens(p, out, "")
        t.languages.set_language("pt")
        QTest.qWait(50)
        tablet_screens(p, out, "_pt")
        t.languages.set_language("en")

        # 4. Take me there: the robot drives, both programs show it.
        if t.session.lost:  # a loaded machine can starve the robot's localiser: ask again
            help_me(p, START_NODE)
        t.show_map()
        click(t.map_view.room_button(GOAL_ROOM))
        click(t.dialog.go_button)  # type: ignore[union-attr]
        p.wait(
            lambda: s.selected.state.plan is not None and bool(s.selected.state.plan.points),
            20,
            "a plan",
        )
        p.wait(lambda: (t.session.goal is not None and t.session.goal.progress >= 30), 60,
               "the robot to be on its way")  # fmt: skip
        save(grab_with_dialog(t), out, "tablet_going_1280x800")
        for index, name in enumerate(TAB_NAMES):
            p.station_window.tabs.setCurrentIndex(index)
            if name == "diagnostics":
                p.station_window.diagnostics_panel.redraw()
            QTest.qWait(300)
            save(p.station_window.grab(), out, f"station_{name}")
        p.station_window.tabs.setCurrentIndex(0)
        p.wait(lambda: t.session.goal is None, 120, "the robot to arrive")
        save(grab_with_dialog(t), out, "tablet_arrived_1280x800")

        # 5. A guided tour, to its first stop.
        click(t.map_screen.tour_button)
        p.wait(lambda: t.session.tour_stop is not None, 240, "the first tour stop")
        save(grab_with_dialog(t), out, "tablet_tour_stop_dialog_1280x800")
        save(p.station_window.grab(), out, "station_tour")
    finally:
        p.close()
    fleet_screenshots(args.out, args.speed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
