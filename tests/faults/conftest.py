"""The fault-injection rig (issue 11): real processes on loopback, killed, frozen and flooded.

* the robot daemon is its own process (``python -m robot_daemon.main --sim --auto-localise``),
  so it can be killed with SIGKILL and restarted on the same endpoint, or frozen with SIGSTOP;
* the Base Station is a `StationController` in the test process with its real timers (its
  "restart" is a new controller on a new zenoh session: nothing of the old one survives);
* a tablet is its own process too (``tablet_proc.py``) when it must be frozen or must flood;
* an `Observer` - a third zenoh session subscribed to ``interbot/**`` of each robot - records
  what the robot publishes (its mux output, odometry, route progress, and its status lines,
  which say what it received: "route N: k goal(s)", "emergency stop released") with the wall
  time it arrived: the figures and the assertions come from it, never from inside a process.

Every endpoint is ``tcp/127.0.0.1:PORT`` on a port the OS handed out, held for the daemon until
it listens (tests/ports.py); scouting is off.
Waits are generous (a loaded 2-core machine); the safety properties are asserted exactly.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh

from base_station_app.station_config import StationConfig
from base_station_app.station_controller import StationController, Timing
from interbot_core.topics import Topic, decode, parse_key
from interbot_core.topological_map import TopologicalMap, load_topological_map
from interbot_link import session_config
from robot_daemon.config import DEFAULT_TOPO
from tests.ports import reserve_port

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
STATION_TIMING = Timing(clock_ms=100, frame_ms=25, ping_ms=500)
START_TIMEOUT = 40.0  # [s] a daemon process to come up on a loaded machine


class DaemonProcess:
    """``interbot-daemon --sim`` in its own process; start, SIGKILL, SIGSTOP, restart."""

    def __init__(self, robot_id: str, log_dir: Path, *extra: str) -> None:
        self.robot_id = robot_id
        self.port = reserve_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.log_dir = log_dir
        self.extra = extra
        self.proc: subprocess.Popen[bytes] | None = None
        self.starts = 0

    def start(self) -> None:
        """Start (or restart) the daemon on its endpoint; the port is held for it (tests/ports.py)
        from here until it listens, seconds later on a loaded machine."""
        self.starts += 1
        reserve_port(self.port)  # again after a kill: nobody's bind(0) gets it meanwhile
        # The mux output on every 20 ms loop pass (pose_hz >= the loop rate), so that what the
        # observer sees is when the motors got a command, not when the next 20 Hz report left.
        config = self.log_dir / f"{self.robot_id}.yaml"
        config.write_text("rates: {pose_hz: 100}\n", "utf-8")
        cmd = [sys.executable, "-m", "robot_daemon.main", "--sim", "--config", str(config)]
        cmd += ["--robot-id", self.robot_id, "--listen", self.endpoint, "--people", "0"]
        cmd += ["--auto-localise", *self.extra]
        log = (self.log_dir / f"{self.robot_id}-{self.starts}.log").open("wb")
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        env.pop("NOTIFY_SOCKET", None)
        self.proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=REPO)
        log.close()

    def log(self) -> str:
        return (self.log_dir / f"{self.robot_id}-{self.starts}.log").read_text(errors="replace")

    def kill9(self) -> None:
        assert self.proc is not None
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10.0)

    def signal(self, sig: signal.Signals) -> None:
        assert self.proc is not None
        self.proc.send_signal(sig)

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGCONT)
            self.proc.terminate()
            try:
                self.proc.wait(10.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


@dataclass(frozen=True)
class Seen:
    """One message the observer received: arrival [s, time.monotonic], robot, topic, message."""

    t: float
    robot: str
    topic: Topic
    message: Any


class Observer:
    """A zenoh session that records every ``interbot/**`` message it can decode."""

    def __init__(self, endpoints: list[str]) -> None:
        self.session = zenoh.open(session_config([], endpoints))
        self._lock = threading.Lock()
        self.seen: list[Seen] = []
        self._sub = self.session.declare_subscriber("interbot/**", self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        t = time.monotonic()
        try:
            robot, name = parse_key(str(sample.key_expr))
            topic = Topic(name)
        except ValueError:
            return
        if topic in (Topic.SCAN, Topic.IMAGE, Topic.MAP):
            return
        try:
            message = decode(topic, sample.payload.to_bytes())
        except ValueError:
            return
        with self._lock:
            self.seen.append(Seen(t, robot, topic, message))

    def of(self, topic: Topic, robot: str | None = None, since: float = -math.inf) -> list[Seen]:
        with self._lock:
            return [
                s
                for s in self.seen
                if s.topic is topic and s.t >= since and (robot is None or s.robot == robot)
            ]

    def last(self, topic: Topic, robot: str | None = None) -> Any:
        found = self.of(topic, robot)
        return found[-1].message if found else None

    def robot_said(self, robot: str, pattern: str, since: float = -math.inf) -> list[str]:
        """The robot's status lines matching ``pattern`` (regex): what it *received* and did
        (e.g. ``route \\d+: \\d+ goal`` for each route it was given)."""
        rx = re.compile(pattern)
        return [
            s.message.text for s in self.of(Topic.STATUS, robot, since) if rx.search(s.message.text)
        ]

    def routes_received(self, robot: str, since: float = -math.inf) -> list[str]:
        return self.robot_said(robot, r"^route \d+: \d+ goal", since)

    def travelled(self, robot: str, since: float, until: float = math.inf) -> float:
        """Path length [m] of the robot's odometry between ``since`` and ``until``."""
        odom = [s.message for s in self.of(Topic.ODOM, robot, since) if s.t <= until]
        return sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(odom))

    def travelled_robot_time(self, robot: str, since: float, until: float = math.inf) -> float:
        """Path length [m] of the robot's odometry stamped (robot clock) in ``[since, until]``."""
        odom = [s.message for s in self.of(Topic.ODOM, robot) if since <= s.message.stamp <= until]
        odom.sort(key=lambda o: o.stamp)
        return sum(math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(odom))

    def zeroed_at(self, robot: str) -> float:
        """Robot time [s] its multiplexer's output last went to no source (the motors' zero)."""
        mux = sorted((s.message for s in self.of(Topic.MUX, robot)), key=lambda m: m.stamp)
        driven = max((m.stamp for m in mux if m.source is not None), default=-math.inf)
        return min(m.stamp for m in mux if m.source is None and m.stamp > driven)

    def newest_stamp(self, topic: Topic, robot: str) -> float:
        """The robot's clock [s] as far as its ``topic`` messages received so far tell."""
        return max((s.message.stamp for s in self.of(topic, robot)), default=-math.inf)

    def close(self) -> None:
        self._sub.undeclare()
        self.session.close()


@dataclass
class Rig:
    qtbot: Any
    tmp: Path
    topo: TopologicalMap
    observer_endpoints: list[str]
    resources: list[Callable[[], None]]

    def wait(self, predicate: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            self.qtbot.wait(5)

    def daemon(self, robot_id: str, *extra: str) -> DaemonProcess:
        d = DaemonProcess(robot_id, self.tmp, *extra)
        d.start()
        self.resources.append(d.close)
        return d

    def observer(self, *daemons: DaemonProcess) -> Observer:
        obs = Observer([d.endpoint for d in daemons])
        self.resources.append(obs.close)
        return obs

    def station(
        self, *daemons: DaemonProcess, robot: str | None = None, config: StationConfig | None = None
    ) -> StationController:
        session = zenoh.open(session_config([], [d.endpoint for d in daemons]))
        station = StationController(
            self.topo,
            session,
            topo_path=DEFAULT_TOPO,
            tablet_port=0,
            robot_id=robot,
            timing=STATION_TIMING,
            config=config,
        )
        closed = False

        def close() -> None:
            nonlocal closed
            if not closed:
                closed = True
                station.shutdown()
                session.close()
                station.deleteLater()

        station.destroyed_by_test = close  # type: ignore[attr-defined]
        self.resources.append(close)
        assert station.start()
        return station

    def online(
        self, station: StationController, robot: str, timeout: float = START_TIMEOUT
    ) -> None:
        """Wait until the station follows ``robot``, has released its start latch and has a pose."""
        self.wait(
            lambda: (
                station.selected_robot == robot
                and station.robot_online
                and not station.selected.stop_assert_pending
                and station.selected.state.localised_pose is not None
            ),
            timeout,
            f"the station to follow robot {robot} (localised, start latch released)",
        )

    def tablet(self, station: StationController, mode: str) -> subprocess.Popen[str]:
        cmd = [sys.executable, str(HERE / "tablet_proc.py"), str(station.tablet.port), mode]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)

        def close() -> None:
            if proc.poll() is None:
                proc.send_signal(signal.SIGCONT)
                proc.kill()
            proc.wait()
            if proc.stdout is not None:
                proc.stdout.close()

        self.resources.append(close)
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "ready"
        return proc


@pytest.fixture
def rig(qtbot: Any, tmp_path: Path) -> Iterator[Rig]:
    resources: list[Callable[[], None]] = []
    r = Rig(qtbot, tmp_path, load_topological_map(DEFAULT_TOPO), [], resources)
    try:
        yield r
    finally:
        for close in reversed(resources):
            close()
        qtbot.wait(10)
