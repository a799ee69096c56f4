"""Issue 14's tail, fifth session: the station gives zenoh's transmit threads (which send the
tablet's commands) the tablet thread's real-time priority where the OS allows it, and not its
receiving threads (display data); it looks for them every second while its timers run (zenoh
starts them lazily) and says what it got in the status log, where the operator sees a
refusal."""

from __future__ import annotations

import contextlib
import os
import threading

import pytest
import zenoh

from base_station_app.station_controller import NETWORK_THREAD_SCAN_MS, StationController
from interbot_link import session_config
from interbot_link.command_priority import TASK_DIR, is_realtime, raise_current_thread

pytestmark = pytest.mark.skipif(
    not hasattr(os, "sched_setscheduler"), reason="no POSIX real-time scheduling here"
)


def granted() -> bool:
    box: list[bool] = []
    thread = threading.Thread(target=lambda: box.append(raise_current_thread("probe").realtime))
    thread.start()
    thread.join()
    return box[0]


@pytest.mark.skipif(not TASK_DIR.is_dir(), reason="no /proc/self/task (not Linux)")
def test_the_station_raises_zenohs_threads_and_says_so(linked: StationController) -> None:
    station = linked
    try:
        station.network_timer.timeout.emit()  # what the timer does every second
        outcome = station.robot_link.network_threads.outcome
        assert outcome is not None
        names = set(station.robot_link.network_threads.raised.values())
        # Only the threads that send the commands; the receiving ones bring display data.
        assert names and all(n.startswith("tx-") for n in names)
        texts = [e.text for e in station.selected.state.log]
        assert outcome.text in texts and "the station's zenoh threads" in outcome.text
        assert outcome.realtime == granted()
        if outcome.realtime:
            assert all(is_realtime(tid) for tid in station.robot_link.network_threads.raised)
        station.network_timer.timeout.emit()
        assert [e.text for e in station.selected.state.log].count(outcome.text) == 1  # once
    finally:
        for tid in station.robot_link.network_threads.raised:  # this test process: back to normal
            with contextlib.suppress(OSError):
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))


def test_the_look_runs_every_second_with_the_timers_and_a_session(
    qtbot, topo, clock, robot
) -> None:
    session = zenoh.open(session_config([], [robot.endpoint]))
    online = StationController(topo, session, clock=clock, tablet_port=0)
    offline = StationController(topo, None, clock=clock, tablet_port=0)
    try:
        online.start()
        offline.start()
        assert online.network_timer.isActive()
        assert online.network_timer.interval() == NETWORK_THREAD_SCAN_MS == 1000
        assert not offline.network_timer.isActive()  # no session: no zenoh threads to look for
        online.shutdown()
        assert not online.network_timer.isActive()
    finally:
        online.shutdown()
        offline.shutdown()
        session.close()
        for tid in online.robot_link.network_threads.raised:  # this test process: back to normal
            with contextlib.suppress(OSError):
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
