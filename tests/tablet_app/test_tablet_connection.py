"""TabletConnection against a real QTcpServer on 127.0.0.1: hello, pings, framing, reconnect."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest
from PySide6.QtNetwork import QAbstractSocket

from interbot_core.protocol import Goal, GoalStatus, Ping, Pose, ShowRequest, TourState
from tablet_app.tablet_connection import ConnectionState

pytestmark = pytest.mark.qt_log_ignore("This plugin does not support propagateSizeHints")


def _connect(qtbot: Any, station: Any, connection: Any) -> None:
    connection.start()
    qtbot.waitUntil(lambda: bool(station.messages("hello")))


def test_hello_is_the_first_line_written_on_connect(qtbot: Any, station: Any, connection: Any):
    with qtbot.waitSignal(connection.connected):
        connection.start()
    qtbot.waitUntil(lambda: bool(station.raw))
    assert station.raw.startswith(b'{"hello":{"protocol":1,"client":"tablet"}}\n')
    assert connection.state == ConnectionState.CONNECTED
    option = connection._link.socket.socketOption(QAbstractSocket.SocketOption.LowDelayOption)
    assert option == 1


def test_answers_a_ping_with_the_same_seq_and_time(qtbot: Any, station: Any, connection: Any):
    _connect(qtbot, station, connection)
    station.send(Ping(41, 12.5))
    qtbot.waitUntil(lambda: bool(station.messages("pong")))
    assert station.messages("pong") == [{"seq": 41, "t": 12.5}]


def test_pings_every_interval_and_reports_average_latency(
    qtbot: Any, station: Any, connection: Any
):
    started = time.monotonic()
    with qtbot.waitSignal(connection.latency_changed, timeout=20000) as blocker:
        _connect(qtbot, station, connection)
    waited_ms = (time.monotonic() - started) * 1000.0
    latency_ms = blocker.args[0]
    # A round trip in milliseconds, inside the wait that saw it (a fixed 300 ms bound is the
    # scheduler's on a loaded machine, not the link's).
    assert 0.0 <= latency_ms <= waited_ms
    pings = station.messages("ping")
    assert pings[0]["seq"] == 1 and isinstance(pings[0]["t"], float)
    assert connection.average_latency_ms is not None
    assert not connection.is_lossy


def test_back_to_back_objects_split_across_writes_become_signals(
    qtbot: Any, station: Any, connection: Any
):
    _connect(qtbot, station, connection)
    received: list[object] = []
    connection.message_received.connect(received.append)
    # Like the thesis's Qt client: indented objects, no delimiter, cut at arbitrary places.
    blob = (
        json.dumps({"pose": {"x_pos": 1.5, "y_pos": -2.0, "angle": 0.785}}, indent=2)
        + json.dumps({"goal": {"goal": 3, "reached": False, "tourReached": False}})
        + json.dumps({"tour_state": {"stops": [0, 3, 4], "visited": [0], "next": 3}})
        + json.dumps(
            {"show_request": {"id": 7, "request": "café ☕", "room": 4, "deliver_to": 0}},
            ensure_ascii=False,
        )
    ).encode("utf-8")
    for start in range(0, len(blob), 17):
        station.send_raw(blob[start : start + 17])
    qtbot.waitUntil(lambda: len(received) == 4)
    assert received == [
        Pose(1.5, -2.0, 0.785),
        GoalStatus(3, False, False),
        TourState((0, 3, 4), (0,), 3),
        ShowRequest(7, "café ☕", 4, 0),
    ]


def test_invalid_message_is_answered_with_an_error_and_the_link_stays(
    qtbot: Any, station: Any, connection: Any
):
    _connect(qtbot, station, connection)
    with qtbot.waitSignal(connection.protocol_error):
        station.send_raw(b'{"pose":{"x_pos":1.0}}')
    qtbot.waitUntil(lambda: bool(station.messages("error")))
    assert station.messages("error")[0]["code"] == "missing_field"
    received: list[object] = []
    connection.message_received.connect(received.append)
    station.send(Pose(0.0, 0.0, 0.0))
    qtbot.waitUntil(lambda: received == [Pose(0.0, 0.0, 0.0)])


def test_reconnects_with_backoff_after_the_station_closes(
    qtbot: Any, station: Any, connection: Any
):
    _connect(qtbot, station, connection)
    port = station.port
    delays: list[float] = []
    connection.reconnect_scheduled.connect(delays.append)
    with qtbot.waitSignal(connection.disconnected):
        station.close()
    assert connection.is_lossy
    qtbot.waitUntil(lambda: len(delays) >= 3)  # refused attempts back off: 0.05, 0.1, 0.2
    assert delays[:3] == [0.05, 0.1, 0.2]
    station.clear()
    station.listen(port)
    with qtbot.waitSignal(connection.connected, timeout=10_000):
        pass
    qtbot.waitUntil(lambda: bool(station.messages("hello")))
    assert station.clients_seen == 2
    assert connection.state == ConnectionState.CONNECTED


def test_link_becomes_lossy_when_pongs_stop_and_recovers(qtbot: Any, station: Any, connection: Any):
    _connect(qtbot, station, connection)
    qtbot.waitUntil(lambda: connection.average_latency_ms is not None)
    assert not connection.is_lossy
    station.answer_pings = False
    with qtbot.waitSignal(connection.link_lossy_changed, timeout=10_000) as blocker:
        pass
    assert blocker.args == [True]
    station.answer_pings = True
    # Pongs answer new pings; the old unanswered ones are overtaken by the newer pong.
    qtbot.waitUntil(lambda: not connection.is_lossy, timeout=10_000)


def test_send_when_not_connected_returns_false(qtbot: Any, connection: Any) -> None:
    assert connection.send(Goal(1)) is False
    assert connection.state == ConnectionState.DISCONNECTED
