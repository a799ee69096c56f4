"""Issue 14: one station supervising five robots through `interbot router`, with real clicks.

Five fake robots (a `RobotLink` each, on its own client session) and the station (a client) meet
at a zenoh router on 127.0.0.1 (OS-chosen port). With no ``--robot`` and no saved choice the
station asks which robot to command (a dialog, answered by a click); the map shows every robot
(name label, state colour, footprint); the operator commands another robot with clicks on the
robot list and on the map; each robot gets its own queue and only its own routes; a robot that
is not selected finishes its task and its next queued task starts (per-robot supervision); the
emergency stop reaches all five (while only robots the operator commanded have their start latch
released); a restarted station commands the saved choice without asking.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest
from PySide6.QtCore import QPoint, QPointF, QSettings, Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication

from base_station_app.main_window import ROBOT_KEY, MainWindow
from base_station_app.robot_mirror import Health
from base_station_app.station_controller import StationController, Timing
from interbot_core.supervisor import GoTo, GuidedTour, SupervisorState
from interbot_core.topics import Lock, MuxMsg, PoseMsg, RouteMsg, RouteProgress, Topic
from interbot_core.topological_map import TopologicalMap
from interbot_link import RobotLink, open_session
from interbot_link.router import open_router
from tests.base_station_app.conftest import TabletClient

# The offscreen platform's notes on show() and on the selector's popup; nothing to fix here.
pytestmark = [
    pytest.mark.qt_log_ignore("propagateSizeHints", r"support raise\(\)", "grabbing the keyboard"),
    pytest.mark.timeout(120),
]

TOPO_PATH = Path(__file__).resolve().parents[2] / "maps" / "isr_floor0_topo.yaml"
ROBOTS = [f"bot{i}" for i in range(5)]


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def fleet_net(free_tcp_port: Callable[[], int]) -> Iterator[tuple[str, dict[str, RobotLink]]]:
    """A router and five fake robots, each a client of it."""
    with ExitStack() as stack:
        router = f"tcp/127.0.0.1:{free_tcp_port()}"
        stack.callback(open_router([router]).close)
        links: dict[str, RobotLink] = {}
        for robot_id in ROBOTS:
            session = stack.enter_context(open_session([], [router], "client"))
            links[robot_id] = RobotLink(session, robot_id)
            stack.callback(links[robot_id].close)
        yield router, links


def make_station(
    qtbot, router: str, topo: TopologicalMap, settings: QSettings, clock: FakeClock
) -> tuple[StationController, MainWindow, ExitStack]:
    stack = ExitStack()
    session = stack.enter_context(open_session([], [router], "client"))
    station = StationController(
        topo,
        session,
        topo_path=TOPO_PATH,
        clock=clock,
        tablet_port=0,
        timing=Timing(clock_ms=100, frame_ms=10, ping_ms=1000, choice_grace_ms=300),
    )
    stack.callback(station.shutdown)
    window = MainWindow(station, settings)
    qtbot.addWidget(window)
    window.resize(1400, 900)
    window.show()
    qtbot.waitExposed(window)
    assert station.start(timers=False)
    return station, window, stack


def publish_poses(
    links: dict[str, RobotLink], topo: TopologicalMap
) -> dict[str, tuple[float, float]]:
    """Each robot localised on its own node, far apart."""
    where = {}
    for i, (robot_id, link) in enumerate(links.items()):
        node = topo.nodes[3 + 4 * i].pose
        link.publish(Topic.POSE, PoseMsg(node.x, node.y, node.yaw, state="ok"))
        where[robot_id] = (node.x, node.y)
    return where


def routes_of(link: RobotLink, seen: dict[str, list[RouteMsg]], robot_id: str) -> list[RouteMsg]:
    for c in link.poll_commands():
        if c.topic is Topic.ROUTE and isinstance(c.message, RouteMsg):
            seen.setdefault(robot_id, []).append(c.message)
        if c.topic is Topic.STOP and isinstance(c.message, Lock):
            seen.setdefault(f"{robot_id}/stop", []).append(c.message)  # type: ignore[arg-type]
        if c.topic is Topic.STOP_RELEASE:
            seen.setdefault(f"{robot_id}/release", []).append(c.message)  # type: ignore[arg-type]
    return seen.get(robot_id, [])


def map_pixel(window: MainWindow, x: float, y: float) -> QPoint:
    view = window.map_view
    return view.mapFromScene(view.getPlotItem().vb.mapViewToScene(QPointF(x, y)))


def choose_in_selector(qtbot, window: MainWindow, robot_id: str) -> None:
    """Open the toolbar's robot selector with a click, then click the robot's row."""
    combo = window.robot_selector
    QTest.mouseClick(combo, Qt.MouseButton.LeftButton)
    view = combo.view()
    qtbot.waitUntil(view.isVisible, timeout=10_000)
    qtbot.wait(QApplication.doubleClickInterval() + 50)  # the popup ignores an early release
    row = view.visualRect(combo.model().index(combo.findData(robot_id), 0))
    QTest.mouseClick(
        view.viewport(),
        Qt.MouseButton.LeftButton,
        pos=row.intersected(view.viewport().rect()).center(),
    )


def click_row(qtbot, window: MainWindow, robot_id: str) -> None:
    panel = window.robots_panel
    window.tabs.setCurrentWidget(panel)
    item = panel.row_of(robot_id)
    assert item is not None
    rect = panel.robot_list.visualItemRect(item)
    QTest.mouseClick(panel.robot_list.viewport(), Qt.MouseButton.LeftButton, pos=rect.center())
    QTest.mouseClick(panel.select_button, Qt.MouseButton.LeftButton)


def test_five_robots_each_shown_each_with_its_own_queue_commanded_by_clicks(
    qtbot, fleet_net, topo: TopologicalMap, tmp_path
) -> None:
    router, links = fleet_net
    settings = QSettings(str(tmp_path / "station.ini"), QSettings.Format.IniFormat)
    clock = FakeClock()
    station, window, stack = make_station(qtbot, router, topo, settings, clock)
    seen: dict[str, list[RouteMsg]] = {}
    with stack:
        # 1. Five robots, no --robot, no saved choice: the station asks, and waits for a click.
        def all_online() -> bool:
            station.poll_link()
            return sorted(r for r, up in station.robots.items() if up) == ROBOTS

        qtbot.waitUntil(all_online, timeout=15000)
        station.poll_link()
        assert station.selected_robot is None and window.robot_choice is None  # grace running
        clock.now += 0.5
        station.tick()
        dialog = window.robot_choice
        assert dialog is not None and dialog.isVisible()
        assert sorted(dialog.buttons) == ROBOTS
        QTest.mouseClick(dialog.buttons["bot3"], Qt.MouseButton.LeftButton)
        assert station.selected_robot == "bot3" and not dialog.isVisible()
        assert settings.value(ROBOT_KEY) == "bot3"
        assert any(
            "choose the one to command" in e.text for e in station.selected.state.log
        )  # one log
        assert window.robot_selector.currentText() == "bot3"

        # 2. Every robot on the map: label with its name and state colour, footprint.
        where = publish_poses(links, topo)

        def all_drawn() -> bool:
            # Poses are a DROP stream (`interbot_link.qos`): a loaded sender may drop one, so
            # every robot publishes again, as a daemon does every period (once, one of the
            # five never arrived in 10 s under load).
            publish_poses(links, topo)
            links["bot3"].publish(Topic.POSE, PoseMsg(*where["bot3"], 0.0, state="ok"))
            station.poll_link()
            views = {v.robot_id: v for v in station.fleet.views(station.names)}
            return all(views[r].pose is not None for r in ROBOTS)

        qtbot.waitUntil(all_drawn, timeout=10000)
        window.map_view.redraw()
        layer = window.map_view.fleet_layer
        for robot_id in ROBOTS:
            body, _path, label = layer._items[robot_id]
            assert robot_id in label.toPlainText() and "ok" in label.toPlainText()
            assert (len(body.getData()[0]) > 0) == (robot_id != "bot3")  # bot3: the map's own

        def bot1_stopped() -> bool:  # the mux is a DROP stream too: published until it arrives
            links["bot1"].publish(Topic.MUX, MuxMsg(None, active_locks=("Emergency Stop",)))
            station.poll_link()
            return station.fleet.mirror("bot1").health is Health.STOPPED

        qtbot.waitUntil(bot1_stopped, timeout=10_000)
        window.map_view.redraw()
        assert "stopped" in layer._items["bot1"][2].toPlainText()

        # 3. Commanded by clicks: bot1 from the robot list, two tasks; bot4 by clicking it.
        click_row(qtbot, window, "bot1")
        assert station.selected_robot == "bot1"
        assert station.submit(GoTo(10)) and station.submit(GoTo(14))
        station.tick()
        x, y = where["bot4"]
        QTest.mouseClick(
            window.map_view.viewport(), Qt.MouseButton.LeftButton, pos=map_pixel(window, x, y)
        )
        assert station.selected_robot == "bot4"
        assert station.submit(GoTo(20))
        station.tick()
        bot1, bot4 = station.fleet.mirror("bot1"), station.fleet.mirror("bot4")
        assert bot1.supervisor.current_task == GoTo(10) and bot1.supervisor.queue == (GoTo(14),)
        assert bot4.supervisor.current_task == GoTo(20) and bot4.supervisor.queue == ()

        def routes(robot_id: str) -> list[RouteMsg]:
            return routes_of(links[robot_id], seen, robot_id)

        qtbot.waitUntil(
            lambda: len(routes("bot1")) == 1 and len(routes("bot4")) == 1, timeout=10_000
        )
        assert bot1.route is not None and routes("bot1")[0].route_id == bot1.route.route_id
        assert all(routes(r) == [] for r in ("bot0", "bot2", "bot3"))

        # 3b. The tablet is bound to the commanded robot (bot4): its goal joins bot4's queue.
        tablet = TabletClient(station.tablet.port)
        stack.callback(tablet.close)
        qtbot.waitUntil(lambda: station.tablet.is_connected, timeout=10_000)
        tablet.send({"goal": 16})
        qtbot.waitUntil(lambda: GoTo(16) in bot4.supervisor.queue, timeout=10_000)
        assert GoTo(16) not in bot1.supervisor.queue and station.tablet_policy.tasks

        # 4. bot1 (not selected) finishes: its next task starts and only bot1 gets the route.
        first = bot1.route.route_id
        links["bot1"].publish(Topic.ROUTE_PROGRESS, RouteProgress(first, 1, True, "succeeded"))

        def next_started() -> bool:
            station.poll_link()
            station.tick()
            return bot1.supervisor.current_task == GoTo(14) and len(routes("bot1")) == 2

        qtbot.waitUntil(next_started, timeout=10_000)
        assert routes("bot1")[1].route_id != first
        assert len(routes("bot4")) == 1 and bot4.supervisor.current_task == GoTo(20)

        # Start latches are released only on the robots the operator commanded from here.
        for r in ROBOTS:
            routes(r)
        released = {r for r in ROBOTS if seen.get(f"{r}/release")}
        assert released == {"bot1", "bot3", "bot4"}

        # 4b. bot2 is chosen in the toolbar selector (clicks) and starts a tour; the operator
        # then commands bot0; bot2 reaches its tour stop unselected: it waits there, an alert
        # names it (the operator must command it to resume).
        choose_in_selector(qtbot, window, "bot2")
        assert station.selected_robot == "bot2" and window.robot_selector.currentText() == "bot2"
        assert station.submit(GuidedTour())
        station.tick()
        bot2 = station.fleet.mirror("bot2")
        stop = bot2.supervisor.next_tour_stop
        assert stop is not None
        click_row(qtbot, window, "bot0")
        assert station.selected_robot == "bot0"
        at = topo.node(stop, "stop").pose
        links["bot2"].publish(Topic.POSE, PoseMsg(at.x, at.y, at.yaw, state="ok"))
        qtbot.waitUntil(lambda: len(routes("bot2")) == 1, timeout=10_000)
        tour_route = routes("bot2")[0]  # the robot says it arrived (it judges arrival)
        last = len(tour_route.waypoints) - 1
        links["bot2"].publish(
            Topic.ROUTE_PROGRESS, RouteProgress(tour_route.route_id, last, True, "succeeded")
        )

        def waiting() -> bool:
            station.poll_link()
            station.tick()
            return any(a.kind == "waiting" and a.robot == "bot2" for a in station.alerts.alerts)

        qtbot.waitUntil(waiting, timeout=10_000)
        assert bot2.supervisor.state is SupervisorState.AT_TOUR_STOP
        assert station.selected.supervisor.current_task is None  # bot0's queue is its own

        # 5. The emergency stop reaches every robot, selected or not.
        QTest.mouseClick(window.estop_button, Qt.MouseButton.LeftButton)

        def all_stopped() -> bool:
            station.tick()
            for r in ROBOTS:
                routes(r)
            return all(any(m.engaged for m in seen.get(f"{r}/stop", [])) for r in ROBOTS)

        qtbot.waitUntil(all_stopped, timeout=10_000)

    # 6. A restarted station commands the saved choice (bot0, the last clicked) without asking.
    assert settings.value(ROBOT_KEY) == "bot0"
    clock2 = FakeClock()
    station2, window2, stack2 = make_station(qtbot, router, topo, settings, clock2)
    with stack2:

        def selected() -> bool:
            station2.poll_link()
            clock2.now += 0.1
            station2.tick()
            return station2.selected_robot == "bot0"

        qtbot.waitUntil(selected, timeout=10000)
        assert window2.robot_choice is None
