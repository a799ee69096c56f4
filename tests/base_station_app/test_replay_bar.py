"""The station's replay bar: shown only for a replayed robot, forwarding play/pause/speed/seek."""

from __future__ import annotations

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest

from base_station_app.qt_replay_bar import TICKS_PER_S, QtReplayBar
from base_station_app.station_controller import StationController
from interbot_core.replay_control import ReplayCommand, ReplayState
from interbot_link.replay import ReplayControlClient, ReplayControlServer


@pytest.mark.qt_log_ignore("propagateSizeHints")  # the offscreen platform's note on show()
def test_the_bar_shows_a_replay_and_forwards_the_users_input(
    qtbot, station: StationController, robot, clock
) -> None:
    assert station.link is not None
    client = ReplayControlClient(station.link.session)
    bar = QtReplayBar(station, client, clock=clock)
    qtbot.addWidget(bar)
    bar.show()
    station.poll_link()
    assert bar.isHidden(), "a robot that is not a replay has no replay bar"

    server = ReplayControlServer(robot.session, "r1")
    try:

        def shown() -> bool:
            server.publish_state(ReplayState(False, 1.0, 12.0, 90.0, "r1_rec.mcap"))
            station.poll_link()
            return bar.isVisible()

        qtbot.waitUntil(shown, timeout=10_000)
        assert bar.slider.maximum() == 90 * TICKS_PER_S
        assert bar.slider.value() == 12 * TICKS_PER_S
        assert bar.time_label.text() == "00:12 / 01:30"
        assert bar.play_button.text() == "Play"

        received: list[ReplayCommand] = []

        def got(n: int) -> bool:
            received.extend(server.poll_commands())
            return len(received) >= n

        QTest.mouseClick(bar.play_button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: got(1), timeout=10_000)
        assert received[0] == ReplayCommand("play")

        bar.speed_box.activated.emit(bar.speed_box.findData(20.0))  # as a pick in the list
        qtbot.waitUntil(lambda: got(2), timeout=10_000)
        assert received[1] == ReplayCommand("speed", 20.0)

        bar.slider.setValue(45 * TICKS_PER_S)
        bar.slider.sliderReleased.emit()
        qtbot.waitUntil(lambda: got(3), timeout=10_000)
        assert received[2] == ReplayCommand("seek", 45.0)

        server.publish_state(ReplayState(True, 20.0, 50.0, 90.0, "r1_rec.mcap"))
        qtbot.waitUntil(
            lambda: (station.poll_link(), bar.play_button.text() == "Pause")[1], timeout=10_000
        )
        assert bar.speed_box.currentData() == 20.0

        clock.advance(5.0)  # the replay stopped answering: no longer shown as one
        station.poll_link()
        assert bar.isHidden()
    finally:
        server.close()
        client.close()
