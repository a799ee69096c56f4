"""The tablet TCP server and its policy, with a raw `socket.socket` tablet on 127.0.0.1 speaking
the thesis's bare JSON objects (no newlines, split across sends)."""

from __future__ import annotations

import json

from PySide6.QtCore import Qt

from base_station_app.station_config import StationConfig
from interbot_core.supervisor import GoTo, GuidedTour, SupervisorState
from interbot_core.topics import RouteMsg, RouteProgress, Topic, Twist
from tests.base_station_app.conftest import robot_arrives


def handshake(qtbot, tablet_factory):
    t = tablet_factory()
    raw = json.dumps({"hello": {"protocol": 1, "client": "tablet"}}, indent=2).encode()
    for i in range(0, len(raw), 7):  # split across several sends, no newline at the end
        t.send_raw(raw[i : i + 7])
    qtbot.waitUntil(lambda: bool(t.of("welcome") and t.of("permissions")), timeout=10_000)
    return t


def test_hello_split_across_sends_gets_welcome_and_permissions(qtbot, station, tablet_factory):
    t = handshake(qtbot, tablet_factory)
    assert t.of("welcome") == [{"protocol": 1, "robot": "r1"}]
    assert t.of("permissions") == [{"teleop": True, "goals": True, "tours": True, "requests": True}]
    assert station.tablet.greeted


def test_pose_stream_initial_pose_false_until_localised(
    qtbot, station, tablet_factory, localise, topo, clock
):
    t = handshake(qtbot, tablet_factory)
    station.tick()
    qtbot.waitUntil(lambda: bool(t.of("initial_pose") == [False]), timeout=10_000)
    assert t.of("localisation") == ["unset"]
    node = topo.nodes[2].pose
    localise(node)
    station.tick()
    qtbot.waitUntil(lambda: bool(len(t.of("pose")) == 1), timeout=10_000)
    assert t.of("pose")[0] == {"x_pos": node.x, "y_pos": node.y, "angle": node.yaw}
    assert t.of("localisation") == ["unset", "ok"]


def test_thesis_client_goal_without_newlines_drives_a_route(
    qtbot, linked, station, robot, tablet_factory, localise, topo
):
    localise(topo.nodes[0].pose)
    t = tablet_factory()  # the thesis's client: no hello, bare objects back to back
    t.send_raw(b'{"goal": 7}{"pau')
    t.send_raw(b'se": false}')
    qtbot.waitUntil(
        lambda: bool(station.selected.supervisor.queue or station.selected.supervisor.current_task),
        timeout=10_000,
    )
    station.tick()
    qtbot.waitUntil(lambda: bool(len(robot.of("route")) == 1), timeout=10_000)
    assert isinstance(robot.of("route")[0], RouteMsg)
    assert robot.of("route")[0].node_ids[-1] == 7
    qtbot.waitUntil(lambda: bool(t.of("goal")), timeout=10_000)
    assert t.of("goal")[-1] == {"goal": 7, "reached": False, "tourReached": False}
    assert station.tablet_requests.task == GoTo(7)
    assert not station.tablet.greeted


def test_second_tablet_is_refused_and_closed(qtbot, station, tablet_factory):
    first = handshake(qtbot, tablet_factory)
    second = tablet_factory()
    qtbot.waitUntil(lambda: bool(second.pump() is True), timeout=10_000)
    assert "another tablet" in second.of("refused")[0]["reason"]
    assert station.tablet.is_connected
    first.send({"ping": {"seq": 1, "t": 2.5}})
    qtbot.waitUntil(lambda: bool(first.of("pong") == [{"seq": 1, "t": 2.5}]), timeout=10_000)


def test_listens_again_after_disconnect(qtbot, station, tablet_factory):
    first = handshake(qtbot, tablet_factory)
    first.close()
    qtbot.waitUntil(lambda: bool(not station.tablet.is_connected), timeout=10_000)
    second = handshake(qtbot, tablet_factory)
    assert second.of("welcome")
    assert station.tablet.is_connected


def test_bad_json_gets_error_reply_and_repeated_errors_close(qtbot, station, tablet_factory):
    t = handshake(qtbot, tablet_factory)
    t.send_raw(b'{"goal": }')
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert t.of("error")[0]["code"] == "invalid_json"
    t.send({"goal": 999})
    qtbot.waitUntil(lambda: bool(len(t.of("error")) == 2), timeout=10_000)
    assert t.of("error")[1]["code"] == "out_of_range"
    assert station.tablet.is_connected
    for _ in range(5):
        t.send({"nonsense": 1})
    qtbot.waitUntil(lambda: bool(t.pump() is True), timeout=10_000)
    assert t.of("error")[-1]["code"] == "unknown_message"
    qtbot.waitUntil(lambda: bool(not station.tablet.is_connected), timeout=10_000)


def test_frame_too_large_closes(qtbot, station, tablet_factory):
    t = handshake(qtbot, tablet_factory)
    t.send_raw(b'{"malfunction": {"kind": "other", "text": "' + b"x" * 70000 + b'"}}')
    qtbot.waitUntil(lambda: bool(t.pump() is True), timeout=10_000)
    assert t.of("error")[-1]["code"] == "frame_too_large"


def test_watchdog_discards_stale_tablet_speed(qtbot, linked, station, robot, tablet_factory, clock):
    """Forwarded once, on arrival; clock() never re-stamps it; the single-shot watchdog (thesis
    Fig. 5.10) sends one explicit zero when the tablet goes silent for the ceiling."""
    station.set_config(StationConfig(latency_ceiling=0.15))
    t = handshake(qtbot, tablet_factory)
    t.send({"speed": {"linear": 0.3, "angular": -0.2}})
    qtbot.waitUntil(lambda: bool(len(robot.of("tablet_vel")) >= 1), timeout=10_000)
    arrived = clock.now
    for _ in range(3):
        clock.advance(0.1)
        station.tick()  # no republishing of the tablet's command
    assert station.tablet_teleop.watchdog.isActive()
    qtbot.waitUntil(lambda: bool(len(robot.of("tablet_vel")) >= 2), timeout=10_000)
    qtbot.wait(300)
    sent = robot.of("tablet_vel")
    assert [(v.linear, v.angular) for v in sent] == [(0.3, -0.2), (0.0, 0.0)]
    assert sent[0].stamp == arrived  # stamped with its arrival, never again
    assert all(isinstance(v, Twist) for v in sent)
    assert station.arbiter.tablet_discarded == 1
    assert station.arbiter.tablet_speed is None
    assert not station.arbiter.tablet_forwarding


def test_out_of_order_and_late_speed_commands_are_dropped(
    qtbot, linked, station, robot, tablet_factory, clock
):
    t = handshake(qtbot, tablet_factory)

    # One read turn each (a burst in one turn passes on only its newest): each command is
    # sent once the server has passed the previous one on (a fixed 30 ms pause let a loaded
    # machine read two in one turn).
    passed_on: list[object] = []
    station.tablet.speed_received.connect(passed_on.append, Qt.ConnectionType.DirectConnection)

    def speed(linear, seq, t_tablet):
        n = len(passed_on)
        t.send({"speed": {"linear": linear, "angular": 0.0, "seq": seq, "t": t_tablet}})
        qtbot.waitUntil(lambda: len(passed_on) > n, timeout=10000)

    speed(0.1, 10, 50.0)  # offset 50 s: the fastest delivery so far
    qtbot.waitUntil(lambda: bool(len(robot.of("tablet_vel")) == 1), timeout=10_000)
    clock.advance(0.1)
    speed(0.2, 9, 49.9)  # out of order
    speed(0.25, 11, 50.1)  # fresh
    qtbot.waitUntil(lambda: bool(len(robot.of("tablet_vel")) == 2), timeout=10_000)
    clock.advance(2.0)  # the tablet froze; its backlog arrives now, 2 s late
    speed(0.3, 12, 50.2)
    speed(0.3, 13, 50.3)
    qtbot.waitUntil(lambda: bool(station.arbiter.freshness.dropped_stale == 2), timeout=10_000)
    qtbot.wait(100)
    assert [v.linear for v in robot.of("tablet_vel") if v.linear] == [0.1, 0.25]
    assert station.arbiter.freshness.dropped_out_of_order == 1


def test_only_the_newest_speed_of_a_burst_is_forwarded(
    qtbot, linked, station, robot, tablet_factory
):
    """A thesis-era tablet's backlog (no seq/t) arriving at once after a stall: one command."""
    t = handshake(qtbot, tablet_factory)
    burst = b"".join(
        json.dumps({"speed": {"linear": 0.01 * k, "angular": 0.0}}).encode() for k in range(1, 21)
    )
    t.send_raw(burst)
    qtbot.waitUntil(lambda: bool(robot.of("tablet_vel")), timeout=10_000)
    qtbot.wait(100)
    assert [v.linear for v in robot.of("tablet_vel")] == [0.2]


def test_no_tablet_speed_forwarded_while_the_stop_is_engaged(
    qtbot, linked, station, robot, tablet_factory
):
    t = handshake(qtbot, tablet_factory)
    station.emergency_stop()
    t.send({"speed": {"linear": 0.3, "angular": 0.0}})
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert "emergency stop" in t.of("error")[0]["message"]
    qtbot.wait(100)
    assert robot.of("tablet_vel") == []


def test_tablet_stop_cancels_a_route_this_station_did_not_start(
    qtbot, linked, station, robot, tablet_factory
):
    """A restarted station: the robot still drives route 77 from before; the tablet is told
    and its stop cancels it."""
    t = handshake(qtbot, tablet_factory)
    robot.link.publish(Topic.ROUTE_PROGRESS, RouteProgress(77, 1, False, "active"))
    qtbot.waitUntil(
        lambda: bool(station.poll_link() or station.selected.route_mirror.foreign), timeout=10_000
    )
    station.tick()
    qtbot.waitUntil(lambda: bool(t.of("status")), timeout=10_000)
    assert "route 77" in t.of("status")[-1]["task"]
    t.send({"stop": True})
    qtbot.waitUntil(lambda: bool(robot.of("route_cancel")), timeout=10_000)
    assert robot.of("route_cancel")[0].route_id is None


def test_speed_period_statistics(qtbot, station, tablet_factory, clock):
    t = handshake(qtbot, tablet_factory)
    for k in range(4):
        t.send({"speed": {"linear": 0.1, "angular": 0.0}})
        qtbot.waitUntil(lambda: station.arbiter.watchdog.last_feed == clock.now, timeout=10_000)
        assert station.arbiter.tablet_periods.total_count == k
        clock.advance(0.1)
    assert station.arbiter.tablet_periods.count == 3
    assert abs(station.arbiter.tablet_periods.mean() - 0.1) < 1e-9


def test_permissions_refuse_goal_and_teleop(qtbot, station, tablet_factory, clock):
    t = handshake(qtbot, tablet_factory)
    station.set_permission("goals", False)
    qtbot.waitUntil(lambda: bool(len(t.of("permissions")) == 2), timeout=10_000)
    assert t.of("permissions")[-1]["goals"] is False
    t.send({"goal": 3})
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert t.of("error")[0]["code"] == "not_permitted"
    assert (
        station.selected.supervisor.queue == () and station.selected.supervisor.current_task is None
    )
    station.set_permission("teleop", False)
    t.send({"speed": {"linear": 0.1, "angular": 0.0}})
    qtbot.waitUntil(lambda: bool(len(t.of("error")) == 2), timeout=10_000)
    assert station.arbiter.tablet_speed is None


def test_station_pings_and_measures_latency(qtbot, station, tablet_factory, clock):
    t = handshake(qtbot, tablet_factory)
    qtbot.waitUntil(lambda: bool(t.of("ping")), timeout=10_000)  # the ping timer (100 ms here)
    ping = t.of("ping")[0]
    clock.advance(0.012)
    measured: list[float] = []  # the signal comes from the tablet thread
    station.tablet.latency_measured.connect(measured.append)
    t.send({"pong": ping})
    qtbot.waitUntil(lambda: len(measured) == 1, timeout=10_000)
    assert abs(measured[0] - 0.012) < 1e-9


def test_tablet_tour_stop_pause_and_resume(
    qtbot, linked, station, robot, tablet_factory, localise, topo
):
    first = topo.tour_nodes()[0]
    localise(first.pose)
    t = handshake(qtbot, tablet_factory)
    t.send({"tour": True})
    qtbot.waitUntil(
        lambda: bool(station.selected.supervisor.queue == (GuidedTour(),)), timeout=10_000
    )
    station.tick()
    robot_arrives(qtbot, station, robot)  # at the first stop already
    assert station.selected.supervisor.state is SupervisorState.AT_TOUR_STOP
    qtbot.waitUntil(
        lambda: bool({"goal": first.id, "reached": True, "tourReached": True} in t.of("goal")),
        timeout=10_000,
    )
    qtbot.waitUntil(
        lambda: bool(t.of("tour_state") and t.of("tour_state")[-1]["visited"] == [first.id]),
        timeout=10_000,
    )
    t.send({"tour_control": "resume"})
    qtbot.waitUntil(
        lambda: bool(station.selected.supervisor.state is not SupervisorState.AT_TOUR_STOP),
        timeout=10_000,
    )
    assert not station.selected.supervisor.paused
    qtbot.waitUntil(
        lambda: bool([lock.engaged for lock in robot.of("pause_nav")] == [True, False]),
        timeout=10_000,
    )


def test_malfunction_goes_to_status_log_and_cancel_by_operator(
    qtbot, station, tablet_factory, localise, topo
):
    t = handshake(qtbot, tablet_factory)
    t.send({"malfunction": {"kind": "collision", "text": "hit a chair"}})
    qtbot.waitUntil(
        lambda: bool(any("hit a chair" in e.text for e in station.selected.state.log)),
        timeout=10_000,
    )
    assert [e.level for e in station.selected.state.log if "hit a chair" in e.text] == ["error"]
    localise(topo.nodes[0].pose)
    t.send({"goal": 9})
    qtbot.waitUntil(lambda: bool(station.selected.supervisor.queue), timeout=10_000)
    station.tick()
    assert station.tablet_requests.task == GoTo(9)
    station.tablet_requests.cancel_task()
    qtbot.waitUntil(lambda: bool(t.of("cancel")), timeout=10_000)
    assert station.selected.supervisor.current_task is None


def test_other_protocol_version_is_refused(qtbot, station, tablet_factory):
    t = tablet_factory()
    t.send({"hello": {"protocol": 2, "client": "future tablet"}})
    qtbot.waitUntil(lambda: t.pump() is True, timeout=10_000)
    assert "protocol 2 is not supported" in t.of("refused")[0]["reason"]
    qtbot.waitUntil(lambda: not station.tablet.is_connected, timeout=10_000)


def test_request_shown_at_room_and_answered_from_tablet(
    qtbot, linked, station, robot, tablet_factory, localise, topo
):
    room = topo.request_nodes()[0]
    t = handshake(qtbot, tablet_factory)
    localise(room.pose)  # the robot already stands at the request room
    t.send(
        {
            "requestFrom": {
                "request": "the blue folder",
                "room": room.id,
                "deliverTo": 0,
                "status": True,
            }
        }
    )
    qtbot.waitUntil(lambda: bool(station.selected.supervisor.queue), timeout=10_000)
    station.tick()
    robot_arrives(qtbot, station, robot)
    assert station.selected.supervisor.state is SupervisorState.AWAITING_RESPONSE
    qtbot.waitUntil(lambda: bool(t.of("show_request")), timeout=10_000)
    shown = t.of("show_request")[0]
    assert shown == {"id": 1, "request": "the blue folder", "room": room.id, "deliver_to": 0}
    t.send({"request_answer": {"id": 1, "accepted": True}})
    qtbot.waitUntil(
        lambda: station.selected.supervisor.state is not SupervisorState.AWAITING_RESPONSE,
        timeout=10_000,
    )
    station.tick()
    # on the way to deliver it
    qtbot.waitUntil(lambda: [r.node_ids[-1] for r in robot.of("route")][-1:] == [0], timeout=10_000)


def _flushed(qtbot, t, seq: int) -> None:
    """Everything the station sent before now has reached the tablet (a ping's pong follows it)."""
    t.send({"ping": {"seq": seq, "t": 0.0}})
    qtbot.waitUntil(lambda: bool({"seq": seq, "t": 0.0} in t.of("pong")), timeout=10_000)


def test_help_me_holds_back_the_stale_lost_state_until_the_robot_answers(
    qtbot, station, robot, tablet_factory, localise, topo, clock
):
    """After "Help me!" the robot's last "lost" is stale until it applies the pose: the tablet
    is not told "lost" again meanwhile (its banner would flash back), and hears "ok" after."""
    t = handshake(qtbot, tablet_factory)
    here = topo.nodes[2].pose
    localise(here, "lost")
    station.tick()
    _flushed(qtbot, t, 1)
    assert t.of("localisation") == ["lost"]
    t.send({"initial_pose_room": 2})
    qtbot.waitUntil(lambda: bool(robot.of("initial_pose")), timeout=10_000)
    for _ in range(10):  # 1 s of clock() with the robot still reporting "lost"
        clock.advance(0.1)
        station.tick()
    _flushed(qtbot, t, 2)
    assert t.of("localisation") == ["lost"]  # nothing new
    localise(here, "ok")
    clock.advance(0.1)
    station.tick()
    _flushed(qtbot, t, 3)
    assert t.of("localisation") == ["lost", "ok"]


def test_help_me_with_a_pose_the_robot_never_takes_says_lost_again_after_the_grace(
    qtbot, station, robot, tablet_factory, localise, topo, clock
):
    from base_station_app.task_commands import INITIAL_POSE_SETTLE_S

    t = handshake(qtbot, tablet_factory)
    localise(topo.nodes[2].pose, "unset")
    station.tick()
    _flushed(qtbot, t, 1)
    unset_count = len(t.of("initial_pose"))
    assert unset_count >= 1 and t.of("localisation") == ["unset"]
    t.send({"initial_pose_room": 2})
    qtbot.waitUntil(lambda: bool(robot.of("initial_pose")), timeout=10_000)
    clock.advance(INITIAL_POSE_SETTLE_S / 2)
    station.tick()
    _flushed(qtbot, t, 2)
    assert len(t.of("initial_pose")) == unset_count  # held back
    clock.advance(INITIAL_POSE_SETTLE_S)
    station.tick()
    _flushed(qtbot, t, 3)
    assert t.of("initial_pose")[unset_count:] == [False]
    assert t.of("localisation") == ["unset", "unset"]  # said afresh


def test_collision_monitor_is_passed_on_to_the_tablet_when_it_changes(
    qtbot, station, tablet_factory
):
    from interbot_core.topics import SafetyMsg, Topic

    t = handshake(qtbot, tablet_factory)
    station.selected.state.apply(
        Topic.SAFETY, SafetyMsg("stop", "FootprintStop", 0.034, 0.1, 0.0, ("tablet_vel",))
    )
    station.tick()
    qtbot.waitUntil(lambda: bool(t.of("safety")), timeout=10_000)
    assert t.of("safety") == [{"zone": "stop", "distance": 0.03, "assisted": True}]
    station.tick()  # unchanged: not sent again
    station.selected.state.apply(Topic.SAFETY, SafetyMsg("none", "", 1000.0, 1000.0, 1.0, ()))
    station.tick()
    qtbot.waitUntil(lambda: len(t.of("safety")) == 2, timeout=10_000)
    assert t.of("safety")[1] == {"zone": "none", "distance": 1000.0, "assisted": False}


# ------------------------------------------------------------------ bounded work (issue 11)
def test_a_flooding_tablet_is_rate_limited_and_its_stop_still_passes(
    qtbot, linked, station, robot, tablet_factory
):
    from base_station_app.tablet_server import MAX_READ_BYTES

    t = handshake(qtbot, tablet_factory)
    flood = json.dumps({"pause": True}).encode() * 2000  # 28 KB: several read turns
    t.send_raw(flood + json.dumps({"stop": True}).encode())
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    error = t.of("error")[0]
    assert error["code"] == "rate_limited" and "dropped" in error["message"]
    qtbot.waitUntil(lambda: station.tablet.policy.dropped > 1500, timeout=10_000)
    assert station.tablet.policy.dropped <= 2000 - 49  # a burst of 50 (hello took one)
    qtbot.waitUntil(lambda: any(e.text == "tablet: stop" for e in station.selected.state.log))
    assert len(flood) > 3 * MAX_READ_BYTES  # it took several turns: the event loop ran between
    assert station.tablet.is_connected  # rate limiting is not a protocol error
    assert len(t.of("error")) <= 2  # one error a second, not one per dropped message


def test_a_tablet_that_answers_no_ping_is_disconnected(qtbot, station, tablet_factory, clock):
    handshake(qtbot, tablet_factory)
    clock.advance(station.tablet.pong_timeout_s + 0.1)  # the ping timer then finds no pong
    qtbot.waitUntil(lambda: not station.tablet.is_connected, timeout=10_000)


def test_a_tablet_that_does_not_read_is_disconnected(qtbot, station, tablet_factory):
    import socket

    from interbot_core.protocol import StatusInfo

    t = handshake(qtbot, tablet_factory)
    t.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    big = StatusInfo("x" * 400, "y" * 400)
    sent = 0
    while station.tablet.is_connected and sent < 40_000:  # up to 32 MB that nobody reads
        for _ in range(100):
            station.tablet.send(big)
        sent += 100
        qtbot.wait(1)
    assert not station.tablet.is_connected
    assert sent * 800 < 16e6  # kernel buffers filled, then at most 256 KiB more were queued


def test_the_tablet_is_told_when_the_robot_is_offline(
    qtbot, linked, station, robot, tablet_factory
):
    t = handshake(qtbot, tablet_factory)
    robot.publish_pose(1.0, 2.0, 0.0)
    qtbot.waitUntil(
        lambda: bool(station.poll_link() or station.selected.state.pose), timeout=10_000
    )
    station.tick()
    qtbot.waitUntil(lambda: bool(t.of("pose")), timeout=10_000)
    robot.link.close()
    qtbot.waitUntil(lambda: bool(station.poll_link() or not station.robot_online), timeout=10_000)
    poses = len(t.of("pose"))
    station.tick()
    qtbot.waitUntil(lambda: bool(t.of("status")) and "offline" in t.of("status")[-1]["message"])
    perms = t.of("permissions")[-1]
    assert not any(perms.values())  # the tablet offers nothing that cannot work
    t.send({"goal": 3})
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert "offline" in t.of("error")[-1]["message"]
    station.tick()
    qtbot.wait(50)
    assert len(t.of("pose")) == poses  # no stale pose
    assert station.selected.supervisor.queue == ()


def test_tablet_socket_has_short_tcp_keepalive(qtbot, station, tablet_factory):
    """A tablet that vanished without a FIN (battery out, Wi-Fi gone) frees the slot in ~11 s."""
    import socket

    from base_station_app.tablet_server import KEEPALIVE

    handshake(qtbot, tablet_factory)
    fd = int(station.tablet._conn.socket.socketDescriptor())
    with socket.fromfd(fd, socket.AF_INET, socket.SOCK_STREAM) as s:
        assert s.getsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE) == 1
        idle = s.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPIDLE)
        interval = s.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPINTVL)
        count = s.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPCNT)
    assert (idle, interval, count) == KEEPALIVE
    assert station.tablet.is_connected  # the duplicate descriptor closed, the connection not


def test_a_robot_switch_tells_the_tablet_the_new_robot_name(qtbot, station, tablet_factory):
    """Issue 14: the welcome names the robot at connect; a switch is said with ``robot``."""
    t = handshake(qtbot, tablet_factory)
    assert t.of("welcome")[0]["robot"] == "r1" and t.of("robot") == []
    station.select_robot("r2")
    qtbot.waitUntil(lambda: t.of("robot") == ["r2"], timeout=10_000)
    station.select_robot("r2")  # no switch: nothing said again
    station.select_robot("r1")
    qtbot.waitUntil(lambda: t.of("robot") == ["r2", "r1"], timeout=10_000)
