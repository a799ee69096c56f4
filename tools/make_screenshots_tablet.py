"""Screenshots of every Tablet screen, offscreen, against an in-process fake Base Station.

    QT_QPA_PLATFORM=offscreen .venv/bin/python tools/make_screenshots_tablet.py [--out DIR]

Writes docs/screenshots/tablet_<screen>_<w>x<h>.png at 2560x1600 (Nexus 10, thesis §4.1.1)
and 1280x800. The fake station feeds a pose, a guided-tour state and a goal, as the Base
Station would during a tour (thesis Fig. 6.2).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QCoreApplication, QPoint, Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QWidget

from interbot_core.protocol import (
    GoalStatus,
    InitialPose,
    Pose,
    ShowRequest,
    TourState,
)
from tablet_app.fake_station import FakeStation
from tablet_app.main import DEFAULT_TOPO, load_plan
from tablet_app.main_window import TabletWindow
from tablet_app.tablet_connection import TabletConnection

logger = logging.getLogger("make_screenshots_tablet")
SIZES = ((2560, 1600), (1280, 800))


def pump(condition: Callable[[], bool] = lambda: False, timeout: float = 0.3) -> None:
    """Run the event loop until ``condition`` holds or ``timeout`` [s] passes."""
    end = time.monotonic() + timeout
    while not condition() and time.monotonic() < end:
        QCoreApplication.processEvents()
        QTest.qWait(10)


def save(widget: QWidget, out: Path, name: str, size: tuple[int, int]) -> None:
    pump()
    path = out / f"tablet_{name}_{size[0]}x{size[1]}.png"
    widget.grab().save(str(path))
    logger.info("wrote %s", path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/screenshots"))
    parser.add_argument("--topo", type=Path, default=DEFAULT_TOPO)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    args.out.mkdir(parents=True, exist_ok=True)
    app = QApplication.instance() or QApplication([sys.argv[0]])
    plan, grid = load_plan(args.topo)
    station = FakeStation()
    port = station.listen()
    connection = TabletConnection("127.0.0.1", port)
    window = TabletWindow(connection, plan, grid)
    window.show()
    connection.start()
    pump(lambda: connection.average_latency_ms is not None, timeout=3.0)
    rooms = plan.touch_rooms()
    tour = tuple(room.id for room in rooms if room.tour)
    visited, nxt = tour[:4], tour[4]
    target = plan.room(nxt)
    previous = plan.room(tour[3])
    x = (previous.x + target.x) / 2.0
    y = (previous.y + target.y) / 2.0
    station.send(Pose(previous.x, previous.y, 0.0))
    station.send(GoalStatus(nxt, False, False))
    station.send(TourState(tour, visited, nxt))
    station.send(Pose(x, y, 0.0))
    pump(lambda: window.motion_bar.isVisible(), timeout=2.0)
    request_room = next(room for room in rooms if room.requests)

    for size in SIZES:
        window.resize(*size)
        window.show_menu()
        save(window, args.out, "menu", size)
        window.show_joystick()
        joystick = window.joystick_screen.joystick
        pump()
        r = joystick.radius()
        press_at = joystick.center().toPoint() + QPoint(-round(r * 0.3), -round(r * 0.6))
        QTest.mousePress(joystick, Qt.MouseButton.LeftButton, pos=press_at)
        save(window, args.out, "joystick", size)
        QTest.mouseRelease(joystick, Qt.MouseButton.LeftButton, pos=press_at)
        window.show_map()
        save(window, args.out, "map_tour", size)
        window.on_room_clicked(request_room.id)
        save(window.dialog, args.out, "room_dialog", size)  # type: ignore[arg-type]
        window.dialog.request_button.click()  # type: ignore[union-attr]
        window.dialog.text_edit.setText("the blue folder")  # type: ignore[union-attr]
        save(window.dialog, args.out, "request_dialog", size)  # type: ignore[arg-type]
        window.dialog.close()  # type: ignore[union-attr]
        station.send(GoalStatus(nxt, True, True))
        pump(lambda: window.dialog is not None, timeout=2.0)
        save(window.dialog, args.out, "tour_stop_dialog", size)  # type: ignore[arg-type]
        window.dialog.close()  # type: ignore[union-attr]
        station.send(ShowRequest(3, "Please sign this form", request_room.id, rooms[0].id))
        pump(lambda: window.dialog is not None, timeout=2.0)
        save(window.dialog, args.out, "show_request_dialog", size)  # type: ignore[arg-type]
        window.dialog.close()  # type: ignore[union-attr]
        station.send(InitialPose(False))
        pump(lambda: window.map_screen.help_banner.isVisible(), timeout=2.0)
        window.map_screen.help_button.click()
        save(window, args.out, "map_help", size)
        window.open_malfunction_dialog()
        save(window.dialog, args.out, "malfunction_dialog", size)  # type: ignore[arg-type]
        window.dialog.close()  # type: ignore[union-attr]
        station.send(Pose(x, y, 0.0))  # localised again for the next size
        station.send(GoalStatus(nxt, False, False))
        pump(lambda: not window.map_screen.help_banner.isVisible(), timeout=2.0)
    connection.stop()
    station.close()
    window.close()
    del app
    return 0


if __name__ == "__main__":
    sys.exit(main())
