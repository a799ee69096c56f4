"""The station's control loop supervising a fleet: cost of ``clock()`` and of the frame poll.

Issue 14 gives every robot its own supervisor, so the station's 100 ms ``clock()`` (thesis Fig.
5.12) now runs one supervisor per robot, and its 25 ms frame poll reads the selected robot's
link and every other robot's light watch. Here a zenoh router (127.0.0.1, OS-chosen port), N
fake robots (a `RobotLink` each, on its own client session, publishing a pose, a planned path
and route progress at 10 Hz as a driving robot would) and a `StationController` (no window, its
timers stepped by this loop) meet; every robot is given a task by the station. The time of each
``tick()`` and ``poll_link()`` call is taken with ``time.perf_counter``.
Targets: ``tick`` and ``poll_link`` well under their periods (100 ms, 25 ms).
"""

from __future__ import annotations

import importlib.util
import math
import socket
import sys
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

_spec = importlib.util.spec_from_file_location("_common", Path(__file__).with_name("_common.py"))
assert _spec is not None and _spec.loader is not None
common = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("_common", common)
_spec.loader.exec_module(common)

ROBOTS, QUICK_ROBOTS = 5, 2
SECONDS, QUICK_SECONDS = 20.0, 3.0
GOALS = (9, 14, 3, 20, 5)


def free_loopback_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def run(quick: bool = False) -> dict[str, Any]:
    from PySide6.QtWidgets import QApplication

    from base_station_app.station_controller import StationController, Timing
    from interbot_core.supervisor import GoTo
    from interbot_core.topics import PlanMsg, PoseMsg, RouteProgress, Topic
    from interbot_core.topological_map import load_topological_map
    from interbot_link import RobotLink, open_session
    from interbot_link.router import open_router

    app = QApplication.instance() or QApplication([sys.argv[0]])
    n = QUICK_ROBOTS if quick else ROBOTS
    duration = QUICK_SECONDS if quick else SECONDS
    topo = load_topological_map(common.ISR_TOPO)
    router = f"tcp/127.0.0.1:{free_loopback_port()}"
    ticks: list[float] = []
    polls: list[float] = []
    with common.quiet_logs(), ExitStack() as stack:
        stack.callback(open_router([router]).close)
        links = {}
        for i in range(n):
            session = stack.enter_context(open_session([], [router], "client"))
            links[f"bench{i}"] = RobotLink(session, f"bench{i}")
            stack.callback(links[f"bench{i}"].close)
        station_session = stack.enter_context(open_session([], [router], "client"))
        station = StationController(
            topo,
            station_session,
            topo_path=common.ISR_TOPO,
            tablet_port=0,
            robot_id="bench0",
            timing=Timing(choice_grace_ms=0),
        )
        stack.callback(station.shutdown)
        station.start(timers=False)
        poses = {r: topo.nodes[3 + 4 * i].pose for i, r in enumerate(links)}
        end = time.monotonic() + 20.0
        while sum(station.robots.values()) < n and time.monotonic() < end:
            station.poll_link()
            app.processEvents()
            time.sleep(0.01)
        for robot_id in links:  # every robot gets a task through the station
            station.select_robot(robot_id)
            pose = poses[robot_id]
            links[robot_id].publish(Topic.POSE, PoseMsg(pose.x, pose.y, pose.yaw, state="ok"))
            end = time.monotonic() + 5.0
            while station.selected.state.localised_pose is None and time.monotonic() < end:
                station.poll_link()
                time.sleep(0.01)
            station.submit(GoTo(GOALS[list(links).index(robot_id) % len(GOALS)]))
            station.tick()
        start = time.monotonic()
        next_tick = next_pub = start
        while time.monotonic() - start < duration:
            now = time.monotonic()
            if now >= next_pub:  # each robot drives: pose, plan and progress at 10 Hz
                next_pub += 0.1
                for robot_id, link in links.items():
                    mirror = station.fleet.mirror(robot_id)
                    pose = poses[robot_id]
                    link.publish(Topic.POSE, PoseMsg(pose.x, pose.y, pose.yaw, state="ok"))
                    route = mirror.route
                    if route is not None:
                        pts = tuple((x, y) for x, y, _ in route.waypoints)
                        link.publish(Topic.PLAN, PlanMsg(route.route_id, pts))
                        link.publish(Topic.ROUTE_PROGRESS, RouteProgress(route.route_id, 0))
            t0 = time.perf_counter()
            station.poll_link()
            polls.append(time.perf_counter() - t0)
            if now >= next_tick:
                next_tick += 0.1
                t0 = time.perf_counter()
                station.tick()
                ticks.append(time.perf_counter() - t0)
            app.processEvents()
            time.sleep(0.025)
        supervised = sum(
            1 for m in station.fleet.mirrors.values() if m.supervisor.current_task is not None
        )
    result: dict[str, Any] = {"station_fleet_robots": n, "station_fleet_supervised": supervised}
    result.update(common.summary_ms(ticks, "station_fleet_tick"))
    result.update(common.summary_ms(polls, "station_fleet_poll"))
    if not ticks:
        result["station_fleet_tick_ms_median"] = math.nan
    return result


if __name__ == "__main__":
    print(run())
