"""The robot daemon driven over zenoh on loopback, as the Base Station drives it.

The daemon runs in a thread of this process on simulated time (8x real time) so tests can also
look inside it; one test runs the real `interbot-daemon` process and stops it with SIGTERM.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field

import pytest

from interbot_core.topics import (
    InitialPose,
    Lock,
    MuxMsg,
    PlanMsg,
    PoseMsg,
    RouteMsg,
    RouteProgress,
    StopRelease,
    Topic,
    Twist,
)
from interbot_link import RobotLink, StateMessage, StationLink, open_session
from interbot_link.command_priority import is_realtime
from interbot_link.robot import Command
from robot_daemon.config import DaemonConfig, SimSettings, ZenohSettings
from robot_daemon.daemon import Daemon, DaemonOptions
from robot_daemon.systemd_notify import SystemdNotifier

ROBOT = "testbot"
pytestmark = pytest.mark.timeout(120)


@dataclass
class Rig:
    daemon: Daemon
    station: StationLink
    stop: threading.Event
    close_station: Callable[[], None]
    link: RobotLink
    loop_thread: threading.Thread
    seen: dict[Topic, object] = field(default_factory=dict)

    def latest(self, topic: Topic) -> object | None:
        """The newest message on ``topic``: high-rate state and events, as a station pumps them."""
        self.seen.update(self.station.poll_state())
        for event in self.station.poll_events():
            if isinstance(event, StateMessage):
                self.seen[event.topic] = event.message
        return self.seen.get(topic)

    def progress(self) -> RouteProgress | None:
        latest = self.latest(Topic.ROUTE_PROGRESS)
        return latest if isinstance(latest, RouteProgress) else None


@pytest.fixture
def rig(free_tcp_port: Callable[[], int], wait_until: Callable[..., None]) -> Iterator[Rig]:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    config = DaemonConfig(
        robot_id=ROBOT,
        sim=SimSettings(seed=3, people=0, odometry="calibrated", realtime_factor=8.0),
        zenoh=ZenohSettings((endpoint,), ()),
        start_latched=False,  # a bare link, not a station: nobody would release the start latch
    )
    daemon = Daemon(config, DaemonOptions(auto_localise=False))
    stop = threading.Event()
    with ExitStack() as robot_side:
        robot_session = robot_side.enter_context(open_session([endpoint], []))
        link = RobotLink(robot_session, ROBOT)
        robot_side.callback(link.close)
        thread = threading.Thread(
            target=daemon.run, args=(link, stop, SystemdNotifier({})), daemon=True
        )
        thread.start()
        station_side = ExitStack()
        station_session = station_side.enter_context(open_session([], [endpoint]))
        station = StationLink(station_session)
        station_side.callback(station.close)
        wait_until(lambda: ROBOT in station.robots, 10.0, "the robot's liveliness token")
        station.select_robot(ROBOT)
        try:
            yield Rig(daemon, station, stop, station_side.close, link, thread)
        finally:
            station_side.close()
            stop.set()
            thread.join(10.0)
            assert not thread.is_alive(), "daemon loop did not stop"


def _localise_at_home(rig: Rig, wait_until: Callable[..., None]) -> None:
    home = rig.daemon.start_pose
    rig.station.send(Topic.INITIAL_POSE, InitialPose(home.x, home.y, home.yaw))

    def localised() -> bool:
        pose = rig.latest(Topic.POSE)
        return isinstance(pose, PoseMsg) and pose.state == "ok"

    wait_until(localised, 10.0, "pose state ok after the initial pose")


def _short_route(rig: Rig) -> RouteMsg:
    """Home (node 0) to the next node of the ring, in the map frame."""
    topo = rig.daemon.topo
    assert topo is not None
    node = topo.node(1).pose
    return RouteMsg(7, ((node.x, node.y, node.yaw),), (1,), 1.0, 0.5, 0.1)


def test_goal_in_route_done_pose_out(rig: Rig, wait_until: Callable[..., None]) -> None:
    pose = rig.latest(Topic.POSE)
    # No pose yet: unset, or searching for itself (issue 16) with no pose (PoseMsg.known).
    assert pose is None or (isinstance(pose, PoseMsg) and not pose.known)
    _localise_at_home(rig, wait_until)
    route = _short_route(rig)
    assert rig.station.send(Topic.ROUTE, route)

    def planned() -> bool:
        plan = rig.latest(Topic.PLAN)
        return isinstance(plan, PlanMsg) and plan.route_id == 7 and len(plan.points) >= 2

    wait_until(planned, 30.0, "the navigator's path for route 7")
    plan = rig.latest(Topic.PLAN)
    assert isinstance(plan, PlanMsg)
    goal_xy = route.waypoints[-1][:2]
    assert math.dist(plan.points[-1], goal_xy) < 0.3  # the path ends at the goal

    def done() -> bool:
        p = rig.progress()
        return p is not None and p.route_id == 7 and p.state == "succeeded"

    wait_until(done, 60.0, "route 7 to succeed")
    progress = rig.progress()
    assert progress is not None and progress.reached_final
    final = rig.latest(Topic.POSE)
    goal = route.waypoints[-1]
    assert isinstance(final, PoseMsg)
    assert abs(final.x - goal[0]) < 0.6 and abs(final.y - goal[1]) < 0.6


def test_command_threads_run_at_real_time_priority_where_allowed(
    rig: Rig, wait_until: Callable[..., None]
) -> None:
    """Issue 14's tail: the threads that receive and apply commands (the link's zenoh callback
    thread, the daemon's command thread) preempt the loop's bulk work (SCHED_FIFO) when the OS
    allows it, and say so either way; the loop itself keeps normal priority."""

    def driving() -> bool:
        rig.station.send(Topic.STATION_VEL, Twist(0.1, 0.0))
        return rig.daemon.stack.last_output.source == "Base Station"

    wait_until(driving, 10.0, "station_vel to win the mux")
    command, callback = rig.daemon.command_priority, rig.link.callback_priority
    assert command is not None and callback is not None
    assert command.realtime == callback.realtime  # one permission for the whole process
    if command.realtime:
        assert "real-time priority" in command.text and "command thread" in command.text
        assert "callback thread" in callback.text
    else:
        assert "not permitted" in command.text or "INTERBOT_REALTIME=0" in command.text
    loop = rig.loop_thread.native_id
    assert loop is not None and not is_realtime(loop)


def test_zenoh_network_threads_run_at_real_time_priority_where_allowed(
    rig: Rig, wait_until: Callable[..., None]
) -> None:
    """Issue 14's tail, fifth session: zenoh's own transmit / receive threads carry the commands
    in and the mux output out; the daemon's loop finds them (zenoh starts them lazily) and
    gives them the command threads' priority, with the same permission, and says so."""

    def driving() -> bool:
        rig.station.send(Topic.STATION_VEL, Twist(0.1, 0.0))
        return rig.daemon.stack.last_output.source == "Base Station"

    wait_until(driving, 10.0, "station_vel to win the mux")
    network = rig.daemon.network_threads
    wait_until(lambda: network.outcome is not None, 10.0, "the daemon's look at zenoh's threads")
    outcome, command = network.outcome, rig.daemon.command_priority
    assert outcome is not None and command is not None
    assert outcome.realtime == command.realtime
    names = set(network.raised.values())
    assert any(n.startswith("tx-") for n in names) and any(n.startswith("rx-") for n in names)
    assert all(n.startswith(("tx-", "rx-", "acc-", "net-")) for n in names)
    if outcome.realtime:
        assert "the daemon's zenoh threads" in outcome.text
        assert all(is_realtime(tid) for tid in network.raised)
    loop = rig.loop_thread.native_id
    assert loop is not None and not is_realtime(loop)


def test_emergency_stop_latches_until_released(rig: Rig, wait_until: Callable[..., None]) -> None:
    def driving() -> bool:
        rig.station.send(Topic.STATION_VEL, Twist(0.2, 0.0))
        return rig.daemon.stack.last_output.source == "Base Station"

    wait_until(driving, 10.0, "station_vel to win the mux")
    rig.station.send(Topic.STOP, Lock(True))
    rig.station.send(Topic.STOP, Lock(False))  # a false value does not release a latched stop
    for _ in range(20):
        rig.station.send(Topic.STATION_VEL, Twist(0.2, 0.0))
        time.sleep(0.02)
    out = rig.daemon.stack.last_output
    assert (out.linear, out.angular, out.source) == (0.0, 0.0, None)
    assert "Emergency Stop" in out.active_locks
    rig.station.send(Topic.STOP_RELEASE, StopRelease("test operator"))
    wait_until(driving, 10.0, "station_vel to drive again after the release")


def test_station_loss_mid_route_still_finishes_the_route(
    rig: Rig, wait_until: Callable[..., None]
) -> None:
    _localise_at_home(rig, wait_until)
    rig.station.send(Topic.ROUTE, _short_route(rig))
    wait_until(
        lambda: (r := rig.daemon.stack.route) is not None and r.state == "active",
        10.0,
        "the route to start",
    )
    rig.close_station()  # the Base Station disappears
    wait_until(
        lambda: rig.daemon.stack.route is not None and rig.daemon.stack.route.finished,
        60.0,
        "the robot to finish the route on its own",
    )
    assert rig.daemon.stack.route is not None and rig.daemon.stack.route.state == "succeeded"


def test_teleop_from_a_vanished_station_stops_within_the_mux_timeout(
    rig: Rig, wait_until: Callable[..., None], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Measured on the robot's clock where things happen: the robot time at which the
    command thread applied the station's last command, and the stamp of the first zero the
    robot published after it. (The robot's clock read when this thread noticed added this
    thread's lag times the realtime factor: at 8x, 100 ms of a loaded machine's scheduling
    were 0.8 s of robot time.)"""
    arrivals: list[float] = []
    apply_motion = rig.daemon.apply_motion

    def recording_arrivals(link: RobotLink, commands: list[Command]) -> None:
        if any(c.topic is Topic.STATION_VEL for c in commands):
            arrivals.append(rig.daemon.now)  # what apply_motion stamps them with
        apply_motion(link, commands)

    mux: list[MuxMsg] = []
    publish = rig.link.publish

    def recording_mux(topic: Topic, message: object) -> None:
        if topic is Topic.MUX and isinstance(message, MuxMsg):
            mux.append(message)
        publish(topic, message)

    monkeypatch.setattr(rig.daemon, "apply_motion", recording_arrivals)
    monkeypatch.setattr(rig.link, "publish", recording_mux)

    def driving() -> bool:
        rig.station.send(Topic.STATION_VEL, Twist(0.3, 0.1))
        return rig.daemon.stack.last_output.linear > 0.0

    wait_until(driving, 10.0, "teleoperation to drive")
    rig.close_station()
    wait_until(lambda: rig.daemon.stack.last_output.source is None, 10.0, "the mux to time out")
    out = rig.daemon.stack.last_output
    assert (out.linear, out.angular) == (0.0, 0.0)
    last = arrivals[-1]

    def zeros() -> list[float]:
        return [m.stamp for m in mux if m.source is None and m.stamp > last]

    wait_until(lambda: bool(zeros()), 10.0, "the zero on the mux topic")
    # station_vel times out 0.5 s of robot time after its last command (plus one loop pass
    # and the state rate's sampling as slack); not before.
    assert 0.5 - 0.05 <= zeros()[0] - last < 0.5 + 0.2, zeros()[0] - last


def test_daemon_process_exits_cleanly_on_sigterm(
    free_tcp_port: Callable[[], int], wait_until: Callable[..., None]
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    cmd = [sys.executable, "-m", "robot_daemon.main", "--sim", "--robot-id", "proc1"]
    cmd += ["--listen", endpoint, "--people", "0"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
    try:
        with open_session([], [endpoint]) as session:
            station = StationLink(session)
            try:
                wait_until(lambda: "proc1" in station.robots, 30.0, "the daemon process")
                proc.send_signal(signal.SIGTERM)
                assert proc.wait(15.0) == 0
                wait_until(lambda: "proc1" not in station.robots, 5.0, "the robot to leave")
            finally:
                station.close()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        output = proc.stdout.read().decode() if proc.stdout else ""
        if proc.stdout:
            proc.stdout.close()
    assert "daemon ready" in output and "daemon stopped" in output
