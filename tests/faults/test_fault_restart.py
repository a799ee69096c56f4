"""Issue 11 faults: a frozen link and a killed daemon, with a route running and the stop engaged.

One daemon process is driven through the whole story, as an unlucky building would:

1. a route runs; the daemon freezes (SIGSTOP) past the link lease, the station sees it leave
   and come back: **no route is sent** (the robot still has it; the station asks, never re-sends);
2. the operator presses EMERGENCY STOP; the daemon is killed (SIGKILL) and restarted: it
   starts latched, the station re-asserts the stop, **the robot does not move** and no route is
   sent; the station tells the task its route is gone;
3. the operator releases the stop: still **no motion** (a restarted robot resumes nothing).
"""

from __future__ import annotations

import signal
import time

import pytest

from interbot_core.supervisor import GoTo
from interbot_core.topics import Topic

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]

ROBOT = "faultbot"
FAR_NODE = 14  # Meeting Room, ~56 m from home: the route is still running when we interfere


def test_link_drop_and_daemon_restart_send_no_route_and_move_nothing(rig) -> None:
    daemon = rig.daemon(ROBOT)
    observer = rig.observer(daemon)
    station = rig.station(daemon, robot=ROBOT)
    rig.online(station, ROBOT)
    assert station.submit(GoTo(FAR_NODE))
    rig.wait(lambda: station.selected.route is not None, 5.0, "the route to be sent")
    route_id = station.selected.route.route_id
    rig.wait(lambda: observer.travelled(ROBOT, 0.0) > 0.2, 30.0, "the robot to drive the route")
    assert len(observer.routes_received(ROBOT)) == 1

    # 1. The link drops (the daemon freezes past the 2.5 s lease) and comes back.
    daemon.signal(signal.SIGSTOP)
    rig.wait(lambda: not station.robot_online, 15.0, "the station to see the robot leave")
    daemon.signal(signal.SIGCONT)
    back = time.monotonic()
    rig.wait(lambda: station.robot_online, 15.0, "the robot to come back")
    rig.wait(
        lambda: not station.selected.route_mirror.checking,
        10.0,
        "the station to learn the robot's route",
    )
    assert (
        station.selected.route is not None and station.selected.route.route_id == route_id
    )  # still ours
    assert observer.routes_received(ROBOT, since=back) == []  # asked, never re-sent

    # 2. EMERGENCY STOP, then the daemon is killed and restarted.
    station.emergency_stop()
    rig.wait(
        lambda: (
            (m := observer.last(Topic.MUX, ROBOT)) is not None
            and "Emergency Stop" in m.active_locks
        ),
        5.0,
        "the robot to report the stop",
    )
    daemon.kill9()
    killed = time.monotonic()
    rig.wait(lambda: not station.robot_online, 10.0, "the station to see the robot die")
    daemon.start()
    rig.wait(lambda: station.robot_online, 40.0, "the restarted robot")
    rig.wait(lambda: bool(observer.of(Topic.ODOM, ROBOT, since=killed)), 10.0, "its odometry")
    first = min(s.t for s in observer.of(Topic.ODOM, ROBOT, since=killed))
    rig.wait(lambda: station.selected.supervisor.current_task is None, 10.0, "the task to end")
    rig.qtbot.wait(3000)
    window = time.monotonic()
    moved = observer.travelled(ROBOT, first, window)
    outputs = [s.message for s in observer.of(Topic.MUX, ROBOT, since=first)]
    print(
        f"\nFAULT motion after a daemon restart with the stop engaged: {moved:.3f} m "
        f"over {window - first:.1f} s ({len(outputs)} mux outputs)"
    )
    assert outputs and all((m.linear, m.angular) == (0.0, 0.0) for m in outputs)
    assert all("Emergency Stop" in m.active_locks for m in outputs[-5:])
    assert moved == 0.0
    assert observer.routes_received(ROBOT, since=killed) == []
    assert observer.robot_said(ROBOT, "emergency stop released", since=killed) == []
    assert any("lost" in e.text and str(route_id) in e.text for e in station.selected.state.log)

    # 3. Released: the restarted robot resumes nothing.
    station.release_stop()
    released = time.monotonic()
    rig.wait(
        lambda: (m := observer.last(Topic.MUX, ROBOT)) is not None and not m.active_locks,
        5.0,
        "the robot to report the release",
    )
    rig.qtbot.wait(1500)
    assert observer.travelled(ROBOT, released) == 0.0
    assert observer.routes_received(ROBOT, since=killed) == []
