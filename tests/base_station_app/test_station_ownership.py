"""Who owns a task: the tablet cancels only its own, a stop holds the queue, everyone is told."""

from __future__ import annotations

import json

from interbot_core.supervisor import GoTo, SupervisorState


def handshake(qtbot, tablet_factory):
    t = tablet_factory()
    t.send_raw(json.dumps({"hello": {"protocol": 1, "client": "tablet"}}).encode())
    qtbot.waitUntil(lambda: bool(t.of("welcome") and t.of("permissions")), timeout=10_000)
    return t


def test_tablet_tasks_are_refused_during_a_stop_and_nothing_starts_on_release(
    qtbot, linked, station, tablet_factory, localise, topo
):
    localise(topo.nodes[0].pose)
    t = handshake(qtbot, tablet_factory)
    station.emergency_stop()
    station.tick()
    qtbot.waitUntil(lambda: t.of("permissions")[-1]["goals"] is False, timeout=10_000)
    t.send({"goal": 9})
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert "emergency stop" in t.of("error")[-1]["message"]
    station.release_stop()
    station.tick()
    assert (
        station.selected.supervisor.current_task is None and station.selected.supervisor.queue == ()
    )


def test_after_a_stop_waiting_tasks_wait_for_resume_queue(qtbot, linked, station, localise, topo):
    localise(topo.nodes[0].pose)
    station.emergency_stop()
    station.submit(GoTo(9))  # the operator queues a task during the stop
    station.tick()
    station.release_stop()
    station.tick()
    assert station.selected.supervisor.current_task is None
    assert station.selected.supervisor.state is SupervisorState.QUEUE_HELD
    station.resume_queue()
    station.tick()
    assert station.selected.supervisor.current_task == GoTo(9)


def test_the_tablet_stop_pauses_an_operators_task_and_says_why(
    qtbot, linked, station, tablet_factory, localise, topo
):
    localise(topo.nodes[0].pose)
    t = handshake(qtbot, tablet_factory)
    station.submit(GoTo(9))  # the operator's task
    station.tick()
    assert station.selected.supervisor.current_task == GoTo(9)
    t.send({"stop": True})
    qtbot.waitUntil(lambda: bool(t.of("error")), timeout=10_000)
    assert t.of("error")[-1]["code"] == "not_owner"
    assert station.selected.supervisor.current_task == GoTo(9)  # still the operator's
    assert station.selected.supervisor.paused  # but the robot has stopped


def test_the_tablet_stop_cancels_its_own_task(
    qtbot, linked, station, tablet_factory, localise, topo
):
    localise(topo.nodes[0].pose)
    t = handshake(qtbot, tablet_factory)
    t.send({"goal": 9})
    qtbot.waitUntil(lambda: bool(station.selected.supervisor.queue), timeout=10_000)
    station.tick()
    assert station.tablet_requests.task == GoTo(9)
    t.send({"stop": True})
    qtbot.waitUntil(lambda: station.selected.supervisor.current_task is None, timeout=10_000)
    assert t.of("cancel") == []  # the tablet did it: no "cancelled by the operator"


def test_an_operator_cancel_of_a_tablet_task_tells_the_tablet(
    qtbot, linked, station, tablet_factory, localise, topo
):
    localise(topo.nodes[0].pose)
    t = handshake(qtbot, tablet_factory)
    t.send({"goal": 9})
    qtbot.waitUntil(lambda: bool(station.selected.supervisor.queue), timeout=10_000)
    station.tick()
    station.commands.cancel_task()  # the task panel's "Cancel current"
    qtbot.waitUntil(lambda: bool(t.of("cancel")), timeout=10_000)
    assert "operator" in t.of("cancel")[-1]["reason"]
