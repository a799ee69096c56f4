"""Alerts: raised on transitions, counted when repeated, acknowledged by the operator."""

from __future__ import annotations

import pytest

from base_station_app.alerts import AlertList, AlertRules
from interbot_core.topics import Battery, PoseMsg, RouteProgress, Status
from robot_daemon.backend import DeviceStatus
from robot_daemon.device_health import DeviceHealth


def rules() -> tuple[AlertList, AlertRules]:
    alerts = AlertList(wall_clock=lambda: 1.7e9)
    return alerts, AlertRules(alerts)


def test_a_repeat_counts_until_acknowledged_then_is_new() -> None:
    alerts = AlertList(wall_clock=lambda: 0.0)
    first = alerts.raise_alert("blocked", "r1", "route aborted: blocked", 1.0)
    again = alerts.raise_alert("blocked", "r1", "route aborted: blocked", 2.0)
    assert (again.id, again.count, again.last) == (first.id, 2, 2.0)
    alerts.acknowledge(first.id)
    assert alerts.unacknowledged == []
    third = alerts.raise_alert("blocked", "r1", "route aborted: blocked", 3.0)
    assert third.id != first.id and len(alerts.unacknowledged) == 1
    alerts.acknowledge_all()
    assert alerts.unacknowledged == []
    with pytest.raises(ValueError):
        alerts.raise_alert("nonsense", "r1", "x", 0.0)


def test_lost_is_raised_when_localisation_goes_from_ok_to_lost_once() -> None:
    alerts, r = rules()
    r.on_pose("r1", PoseMsg(0, 0, 0, state="unset"), 0.0)
    r.on_pose("r1", PoseMsg(0, 0, 0, state="lost"), 0.1)  # never was ok: not a loss
    r.on_pose("r1", PoseMsg(0, 0, 0, state="ok"), 0.2)
    for t in (0.3, 0.4, 0.5):
        r.on_pose("r1", PoseMsg(0, 0, 0, state="lost"), t)
    assert [a.kind for a in alerts.alerts] == ["lost"] and alerts.alerts[0].severe


def test_low_battery_with_hysteresis() -> None:
    alerts, r = rules()
    for soc in (0.5, 0.19, 0.18, 0.22, 0.19, 0.3, 0.15):
        r.on_battery("r1", Battery(24.0, 1.0, soc), 0.0)
    # 19 % once (not again at 18 % or after 22 %: no recovery above 25 %), then 15 % after 30 %
    assert [a.text.split(":")[1].split("%")[0].strip() for a in alerts.alerts] == ["19", "15"]
    assert {a.kind for a in alerts.alerts} == {"battery"}


def test_route_aborted_collision_fault_offline_malfunction_refused() -> None:
    alerts, r = rules()
    aborted = RouteProgress(7, 1, False, "aborted", "blocked: no path")
    r.on_route_progress("r1", aborted, 0.0)
    r.on_route_progress("r1", aborted, 0.5)  # the robot repeats its verdict: one alert
    r.on_status("r1", Status("error", "collision: motors stalled against an obstacle"), 1.0)
    r.on_status("r1", Status("error", "fault: motors: overcurrent"), 1.0)
    r.on_status("r1", Status("info", "route 7 started"), 1.0)  # not an alert
    r.on_robot_left("r1", 2.0)
    r.on_malfunction("wrong_position", "it is in the wrong room", 3.0)
    for t in (4.0, 5.0, 70.0):
        r.on_refused("emergency stop engaged: goal ignored", t)
    kinds = [a.kind for a in alerts.alerts]
    assert kinds == ["blocked", "collision", "fault", "offline", "malfunction", "refused"]
    assert alerts.alerts[-1].count == 2  # once a minute
    assert "wrong position" in alerts.alerts[4].text


def test_device_health_says_faults_and_contacts_once() -> None:
    health = DeviceHealth()
    ok = DeviceStatus("motors", True, "fine", {"contacts": 0})
    assert health.changes([ok]) == []
    touched = DeviceStatus("motors", True, "fine", {"contacts": 2})
    ((level, text),) = health.changes([touched])
    assert level == "error" and text.startswith("collision:") and "2 new contacts" in text
    assert health.changes([touched]) == []
    faulty = DeviceStatus("motors", False, "faults: stall", {"contacts": 2})
    assert health.changes([faulty]) == [("error", "fault: motors: faults: stall")]
    assert health.changes([faulty]) == []
    assert health.changes([ok.__class__("motors", True, "fine", {"contacts": 2})])[0][0] == "info"
