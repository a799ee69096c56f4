"""The end-to-end rig: the three Interbot programs in one test process, on loopback.

* the robot daemon (`robot_daemon.daemon.Daemon`) in a thread, on simulated time running
  ``REALTIME_FACTOR`` times as fast as the wall clock (sim backend, no people, fixed seed, no
  camera, ``auto_localise`` off), listening for zenoh on 127.0.0.1;
* the Base Station's `StationController` connected to it over zenoh, its timers running, its
  tablet server on a port the OS picks;
* the Tablet's `TabletWindow` with its `TabletConnection` to that server.

Tests drive the Tablet with real mouse and touch events and look at the robot (daemon state,
route progress, the simulator's true pose) and back at the Tablet. Everything runs on the Qt
main thread except the daemon loop and zenoh's callback threads; actions on the simulated robot
(a kidnap) are queued to the daemon's thread and run between two simulator steps.

The station keeps wall-clock time (it is another machine); its ``clock()`` runs every 50 ms
instead of 100 ms so that, with the robot's time at 8x, forwarded teleoperation (0.4 s of robot
time apart) stays inside the multiplexer's 0.5 s input timeout.
"""

from __future__ import annotations

import logging
import math
import os
import queue
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import zenoh
from PySide6.QtCore import QPoint, Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QWidget

from base_station_app.station_controller import StationController, Timing
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import load_map
from interbot_core.protocol import GoalStatus, Localisation, ShowRequest
from interbot_core.topological_map import TopologicalMap, load_topological_map
from interbot_link import RobotLink, open_session, session_config
from robot_daemon.config import DEFAULT_TOPO, DaemonConfig, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.sim.odometry_model import OdometryErrorModel
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.sim_backend import SimBackend
from robot_daemon.systemd_notify import SystemdNotifier
from tablet_app.link_health import BackoffConfig, LatencyConfig
from tablet_app.main import load_plan
from tablet_app.main_window import TabletWindow
from tablet_app.tablet_connection import TabletConnection

logger = logging.getLogger(__name__)

ROBOT = "e2ebot"
SEED = 3
REALTIME_FACTOR = 8.0
STATION_TIMING = Timing(clock_ms=50, frame_ms=25, ping_ms=500)
TOPO_PATH = DEFAULT_TOPO
# The offscreen platform warns on every top-level window; that is not a failure.
OFFSCREEN_NOISE = "This plugin does not support propagateSizeHints"


class RigBackend(SimBackend):
    """`SimBackend` that runs queued test actions on the daemon's thread before each step."""

    def __init__(self, simulator: Simulator, scan_rate_hz: float) -> None:
        super().__init__(simulator, scan_rate_hz=scan_rate_hz, camera_rate_hz=0.0)
        self._actions: queue.SimpleQueue[tuple[Callable[[Simulator], None], threading.Event]] = (
            queue.SimpleQueue()
        )

    def call_soon(self, action: Callable[[Simulator], None]) -> threading.Event:
        """Queue ``action(sim)`` for the daemon's thread; the event is set once it ran."""
        done = threading.Event()
        self._actions.put((action, done))
        return done

    def advance(self, now: float) -> None:
        while True:
            try:
                action, done = self._actions.get_nowait()
            except queue.Empty:
                break
            action(self.sim)
            done.set()
        super().advance(now)


@dataclass
class Recorder:
    """Station messages the Tablet received, in order (for what a dialog or banner hides)."""

    goal_status: list[GoalStatus] = field(default_factory=list)
    localisation: list[str] = field(default_factory=list)
    requests: list[ShowRequest] = field(default_factory=list)

    def on_message(self, msg: object) -> None:
        if isinstance(msg, GoalStatus):
            self.goal_status.append(msg)
        elif isinstance(msg, Localisation):
            self.localisation.append(msg.state)
        elif isinstance(msg, ShowRequest):
            self.requests.append(msg)


@dataclass
class Rig:
    """One daemon, one station, one tablet; see the module docstring."""

    qtbot: Any
    daemon: Daemon
    backend: RigBackend
    station: StationController
    window: TabletWindow
    connection: TabletConnection
    topo: TopologicalMap
    seen: Recorder
    realtime_factor: float = REALTIME_FACTOR  # robot time / wall time
    timing: Timing = STATION_TIMING

    # -- the robot ---------------------------------------------------------------------------

    def truth(self) -> Pose2D:
        """The simulated robot's true pose (ground truth, for assertions only)."""
        return self.backend.sim.true_pose()

    def teleport(self, pose: Pose2D) -> float:
        """Kidnap the simulated robot: move it to ``pose`` on the daemon's thread; returns the
        robot time [s] it happened at (read there, not when this thread learns of it)."""
        at: list[float] = []
        done = self.backend.call_soon(lambda sim: (sim.teleport(pose), at.append(sim.time)))
        assert done.wait(10.0), "the daemon loop did not run the teleport"
        return at[0]

    @property
    def localisation(self) -> LocaliserState:
        return self.daemon.stack.localisation_state

    def node_pose(self, node_id: int) -> Pose2D:
        return self.topo.node(node_id).pose

    # -- waiting --------------------------------------------------------------------------------

    def wait(self, predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
        """Process Qt events until ``predicate()``; fail naming ``what`` and the rig's state."""
        deadline = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout_s} s waiting for {what}; {self.describe()}")
            self.qtbot.wait(5)

    def describe(self) -> str:
        stack = self.daemon.stack
        route = stack.route
        route_text = "none" if route is None else f"{route.route_id} {route.state} {route.index}"
        return (
            f"robot t={self.daemon.now:.1f} s truth={self.truth()} estimate={stack.pose} "
            f"localisation={stack.localisation_state.value} mux={stack.last_output} "
            f"route={route_text} station={self.station.selected.supervisor.state} "
            f"tablet={self.connection.state.value}"
        )

    # -- the tablet -------------------------------------------------------------------------------

    @staticmethod
    def click(widget: QWidget) -> None:
        QTest.mouseClick(widget, Qt.MouseButton.LeftButton)

    @staticmethod
    def touch(widget: QWidget, device: Any, action: str, point: QPoint) -> None:
        """One committed touch event at ``point`` (widget coordinates), through the window
        (the QWindow overload maps the point correctly on the offscreen platform)."""
        handle = widget.window().windowHandle()
        sequence = QTest.touchEvent(handle, device, autoCommit=False)
        getattr(sequence, action)(0, widget.mapTo(widget.window(), point))
        sequence.commit()

    def marker_distance_px(self, pose: Pose2D) -> float:
        """Pixels between the tablet's robot marker and where ``pose`` would be drawn
        (infinite while the tablet shows no marker)."""
        marker = self.window.map_view.robot_widget_pos()
        if marker is None:
            return math.inf
        x, y = self.window.map_view.transform.world_to_widget(pose.x, pose.y)
        return math.hypot(marker.x() - x, marker.y() - y)

    def tap_room(self, room_id: int) -> None:
        self.window.show_map()
        self.click(self.window.map_view.room_button(room_id))

    def localise_at(self, node_id: int) -> None:
        """The operator sets the initial pose at ``node_id`` on the station; wait for ok."""
        self.station.commands.set_initial_pose_room(node_id)
        self.wait(lambda: self.localisation == LocaliserState.OK, 10.0, "localisation ok")
        self.wait(
            lambda: (
                self.seen.localisation[-1:] == ["ok"]
                and self.window.map_view.robot_widget_pos() is not None
            ),
            10.0,
            "the tablet to learn that the robot is localised",
        )


def _build_daemon(endpoint: str, start_node: int | None) -> tuple[Daemon, RigBackend]:
    config = DaemonConfig(
        robot_id=ROBOT,
        sim=SimSettings(
            seed=SEED, people=0, odometry="calibrated", realtime_factor=REALTIME_FACTOR
        ),
        zenoh=ZenohSettings((endpoint,), ()),
    )
    topo = load_topological_map(config.topo_yaml)
    start = topo.node(topo.home_id if start_node is None else start_node).pose
    sim = Simulator(
        load_map(config.map_yaml),
        SimConfig(
            start_pose=start, n_people=0, odometry=OdometryErrorModel.named(config.sim.odometry)
        ),
        rng_seed=config.sim.seed,
    )
    rates = config.rates
    backend = RigBackend(sim, scan_rate_hz=max(rates.localiser_hz, rates.scan_hz))
    # The person's "Help me!" flow: the robot does not search the map by itself here.
    options = DaemonOptions(auto_localise=False, start_node=start_node, relocalise=False)
    return Daemon(config, options, backend=backend), backend


@pytest.fixture
def make_rig(qtbot: Any, free_tcp_port: Callable[[], int]) -> Iterator[Callable[..., Rig]]:
    """``make_rig(start_node=None)``: start the three programs (robot not localised)."""
    resources = ExitStack()

    def make(start_node: int | None = None) -> Rig:
        endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
        daemon, backend = _build_daemon(endpoint, start_node)
        # -- the robot ---------------------------------------------------------------------
        robot_session = resources.enter_context(open_session([endpoint], []))
        link = RobotLink(robot_session, ROBOT)
        resources.callback(link.close)
        stop = threading.Event()
        thread = threading.Thread(
            target=daemon.run,
            args=(link, stop, SystemdNotifier({})),
            name="e2e-daemon",
            daemon=True,
        )
        thread.start()

        def stop_daemon() -> None:
            stop.set()
            thread.join(10.0)
            assert not thread.is_alive(), "the daemon loop did not stop"

        resources.callback(stop_daemon)
        # -- the Base Station --------------------------------------------------------------
        station_session = zenoh.open(session_config([], [endpoint]))
        resources.callback(station_session.close)
        topo = load_topological_map(TOPO_PATH)
        station = StationController(
            topo,
            station_session,
            topo_path=TOPO_PATH,
            tablet_port=0,
            robot_id=ROBOT,
            timing=STATION_TIMING,
        )
        resources.callback(station.deleteLater)
        resources.callback(station.shutdown)
        assert station.start(), "the station's tablet server could not listen"
        qtbot.waitUntil(lambda: station.selected_robot == ROBOT, timeout=10_000)
        # -- the Tablet --------------------------------------------------------------------
        plan, grid = load_plan(TOPO_PATH)
        connection = TabletConnection(
            "127.0.0.1",
            station.tablet.port,
            ping_interval=0.25,
            health_interval=0.1,
            latency=LatencyConfig(window=5, pong_timeout=1.0, ceiling=0.5),
            backoff=BackoffConfig(initial=0.05, maximum=0.2),
        )
        resources.callback(connection.deleteLater)
        resources.callback(connection.stop)
        seen = Recorder()
        connection.message_received.connect(seen.on_message)
        window = TabletWindow(connection, plan, grid)
        qtbot.addWidget(window)
        resources.callback(window.close)
        window.resize(1280, 800)
        window.show()
        connection.start()
        qtbot.waitUntil(lambda: station.tablet.greeted and connection.is_connected)
        rig = Rig(qtbot, daemon, backend, station, window, connection, topo, seen)
        # The robot publishes, the station has its pose and sends the tablet the state.
        rig.wait(lambda: station.selected.state.pose is not None, 10.0, "the robot's first pose")
        return rig

    try:
        yield make
    finally:
        resources.close()
        qtbot.wait(10)  # let deleteLater run before the next test's objects exist


def _open_sockets() -> set[str]:
    """The sockets this process holds (``socket:[inode]``), from /proc/self/fd."""
    fd_dir = Path("/proc/self/fd")
    sockets = set()
    for fd in fd_dir.iterdir():
        try:
            target = os.readlink(fd)
        except OSError:  # closed while listing
            continue
        if target.startswith("socket:"):
            sockets.add(target)
    return sockets


@pytest.fixture(autouse=True)
def _no_leaks(qtbot: Any) -> Iterator[None]:
    """Each test leaves no thread and no socket behind (TCP, zenoh links, the tablet's)."""
    threads = set(threading.enumerate())
    sockets = _open_sockets()
    yield
    deadline = time.monotonic() + 5.0
    while True:
        new_threads = [t for t in threading.enumerate() if t not in threads and t.is_alive()]
        new_sockets = _open_sockets() - sockets
        if not new_threads and not new_sockets:
            return
        if time.monotonic() > deadline:
            pytest.fail(f"the test leaked threads {new_threads} and sockets {new_sockets}")
        qtbot.wait(20)
