"""Robots found through the building's router: time from a robot's start to the station seeing it.

A zenoh router (`interbot_link.router`) and a station (`StationLink`, a client) run first; then
robots start one after another, each a simulated robot daemon on its own client session. For
each robot the time is taken from the moment its daemon starts (session opened, liveliness
token declared by `RobotLink`) to the moment the station's robot list holds it (polled every
5 ms). Then the robots stop one by one (clean exit: the session closes) and the time until the station
drops each is taken (a frozen robot is dropped when its link lease expires, 2.5 s).
Everything on 127.0.0.1; target: a robot discovered within 3 s.
"""

from __future__ import annotations

import importlib.util
import socket
import sys
import threading
import time
from contextlib import ExitStack, closing
from pathlib import Path
from typing import Any

_spec = importlib.util.spec_from_file_location("_common", Path(__file__).with_name("_common.py"))
assert _spec is not None and _spec.loader is not None
common = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("_common", common)
_spec.loader.exec_module(common)

ROBOTS, QUICK_ROBOTS = 5, 2
TIMEOUT_S = 20.0


def free_loopback_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def _wait(condition: Any, timeout: float) -> float | None:
    """Seconds until ``condition()`` held (polled every 5 ms), or None on timeout."""
    start = time.perf_counter()
    while time.perf_counter() - start < timeout:
        if condition():
            return time.perf_counter() - start
        time.sleep(0.005)
    return None


def run(quick: bool = False) -> dict[str, Any]:
    from interbot_link import RobotLink, StationLink, open_session
    from interbot_link.router import open_router
    from robot_daemon.config import DaemonConfig, SimSettings, ZenohSettings
    from robot_daemon.daemon import Daemon, DaemonOptions
    from robot_daemon.systemd_notify import SystemdNotifier

    n = QUICK_ROBOTS if quick else ROBOTS
    router = f"tcp/127.0.0.1:{free_loopback_port()}"
    found: list[float] = []
    gone: list[float] = []
    with common.quiet_logs(), ExitStack() as stack:
        router_session = open_router([router])
        stack.callback(router_session.close)
        station_session = stack.enter_context(open_session([], [router], "client"))
        station = stack.enter_context(closing(StationLink(station_session)))
        robots: list[tuple[str, threading.Event, threading.Thread, ExitStack]] = []
        try:
            for i in range(n):
                robot_id = f"fleet{i}"
                config = DaemonConfig(
                    robot_id=robot_id,
                    sim=SimSettings(seed=i, people=0, realtime_factor=1.0),
                    zenoh=ZenohSettings((), (router,), mode="client"),
                )
                daemon = Daemon(config, DaemonOptions(auto_localise=True))
                resources = ExitStack()
                start = time.perf_counter()
                session = resources.enter_context(open_session([], [router], "client"))
                link = RobotLink(session, robot_id)
                resources.callback(link.close)
                stop = threading.Event()
                thread = threading.Thread(
                    target=daemon.run, args=(link, stop, SystemdNotifier({})), daemon=True
                )
                thread.start()
                robots.append((robot_id, stop, thread, resources))
                seen = _wait(lambda rid=robot_id: rid in station.robots, TIMEOUT_S)
                found.append(time.perf_counter() - start if seen is not None else float("nan"))
        finally:
            for robot_id, stop, thread, resources in robots:
                stop.set()
                thread.join(10.0)
                resources.close()  # the robot's session closes: its token goes
                left = _wait(lambda rid=robot_id: rid not in station.robots, TIMEOUT_S)
                gone.append(left if left is not None else float("nan"))
    seen_count = sum(1 for f in found if f == f)
    result: dict[str, Any] = {"fleet_robots": n, "fleet_robots_seen": seen_count}
    result.update(common.summary_ms([f for f in found if f == f], "fleet_discovery"))
    result.update(common.summary_ms([g for g in gone if g == g], "fleet_gone"))
    return result


if __name__ == "__main__":
    print(run())
