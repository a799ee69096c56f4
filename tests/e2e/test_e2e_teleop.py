"""End to end, joystick teleoperation from the Tablet and the Base Station's latency watchdog
(thesis §5.2.2.3, §5.3.4).

Touching the joystick sends ``speed`` every 100 ms; the station forwards it on ``tablet_vel``
to the robot's multiplexer. When the Tablet's link stalls (its socket stops sending while the
finger stays on the joystick), the station's watchdog must discard the stale speed and send a
zero, so the robot stops within the watchdog ceiling (station, wall clock) plus the
multiplexer's input timeout (robot time, 8x faster here) plus one station clock period.

Those intervals are timed where they happen: the station's ``tablet_vel`` sends (tablet
thread) and the robot's motor outputs (daemon threads) are stamped as they are made, not when
this test's thread, polling every 5 ms between Qt events on a loaded machine, gets to see them.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import pytest
from PySide6.QtCore import QPoint
from PySide6.QtTest import QTest

from interbot_core.topics import Topic

pytestmark = [pytest.mark.slow, pytest.mark.qt_log_ignore("This plugin does not support")]

MUX_TABLET_TIMEOUT = 0.5  # [s] robot time (resources/config/interbot_mux.yaml)
SLACK = 0.75  # [s] wall: event-loop and thread scheduling on a shared 2-core machine


@dataclass
class Stamped:
    """(wall time [s], linear, angular) of each command or output, in the order they were made."""

    records: list[tuple[float, float, float]] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, linear: float, angular: float) -> None:
        with self.lock:
            self.records.append((time.monotonic(), linear, angular))

    def first_zero_after(self, t: float) -> float | None:
        with self.lock:
            return next((s for s, v, w in self.records if s > t and (v, w) == (0.0, 0.0)), None)

    def last_moving_before(self, t: float) -> float | None:
        with self.lock:
            moving = [s for s, v, w in self.records if s < t and (v, w) != (0.0, 0.0)]
        return moving[-1] if moving else None


def test_joystick_drives_the_robot_and_a_stalled_link_stops_it(
    make_rig: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    rig = make_rig()
    window, station = rig.window, rig.station
    # What the station sends on tablet_vel (from the tablet thread) and what the robot's
    # multiplexer puts out (loop and command threads), stamped as they happen.
    tablet_vel, outputs = Stamped(), Stamped()
    send, apply_output = station._send, rig.daemon.stack.apply_output

    def stamped_send(topic: Any, message: Any) -> bool:
        if topic is Topic.TABLET_VEL:
            tablet_vel.add(message.linear, message.angular)
        return send(topic, message)

    def stamped_output(now: float) -> Any:
        out = apply_output(now)
        outputs.add(out.linear, out.angular)
        return out

    station._send = stamped_send  # type: ignore[method-assign]
    rig.daemon.stack.apply_output = stamped_output  # type: ignore[method-assign]
    rig.click(window.menu.joystick_button)
    screen = window.joystick_screen
    assert window.stack.currentWidget() is screen
    rig.wait(lambda: screen.warning_label.isHidden(), 5.0, "a healthy link")
    joystick = screen.joystick
    # Right of the centre: turn right on the spot (angular < 0, linear 0).
    point = joystick.center().toPoint() + QPoint(round(joystick.radius() * 0.5), 0)
    device = QTest.createTouchDevice()
    rig.touch(joystick, device, "press", point)

    def tablet_drives() -> bool:
        out = rig.daemon.stack.last_output
        return out.source == "Tablet" and out.angular < -0.1 and out.linear == 0.0

    rig.wait(tablet_drives, 5.0, "tablet_vel to win the robot's multiplexer")
    start_yaw = rig.truth().yaw
    rig.wait(
        lambda: abs(math.remainder(rig.truth().yaw - start_yaw, math.tau)) > 0.2,
        5.0,
        "the robot to turn",
    )
    assert station.arbiter.tablet_forwarding and station.arbiter.tablet_discarded == 0
    assert station.arbiter.watchdog.ceiling_s == 0.5

    # The link stalls: nothing the Tablet writes gets out any more (the finger stays down).
    monkeypatch.setattr(rig.connection._link, "send", lambda _msg: True)
    stalled_at = time.monotonic()

    def stopped() -> bool:
        out = rig.daemon.stack.last_output
        return (out.linear, out.angular) == (0.0, 0.0)

    # The station's watchdog expires one ceiling after the last speed that got through (at most
    # one tablet period, 100 ms, before the stall) and discards the stale speed with a zero.
    ceiling = station.arbiter.watchdog.ceiling_s
    clock_s = rig.timing.clock_ms / 1000
    rig.wait(lambda: station.arbiter.tablet_discarded >= 1, 5.0, "the station's watchdog to expire")
    zero_at = tablet_vel.first_zero_after(stalled_at)
    assert zero_at is not None, tablet_vel.records[-5:]
    last_speed_at = tablet_vel.last_moving_before(zero_at)  # (it may have been in flight)
    assert last_speed_at is not None, tablet_vel.records[-5:]
    assert zero_at - last_speed_at >= ceiling  # never before a ceiling of silence
    assert zero_at - stalled_at < ceiling + clock_s + SLACK
    assert not station.arbiter.tablet_forwarding and station.arbiter.tablet_speed is None
    # The watchdog fires in the tablet thread; its log line reaches the Qt thread queued.
    rig.wait(
        lambda: any(
            "tablet speed stopped (no command for 0.5 s): explicit zero sent" in e.text
            for e in station.selected.state.log
        ),
        2.0,
        "the operator's log to say the tablet speed was stopped",
    )
    # At 8x the stale speed may already have timed out in the robot's multiplexer between two
    # station clocks; either way the robot is stopped within ceiling + clock + mux timeout.
    rig.wait(stopped, 5.0, "the robot to stop after the stall")
    stopped_at = outputs.first_zero_after(stalled_at)
    assert stopped_at is not None
    assert stopped_at - stalled_at < (
        ceiling + clock_s + MUX_TABLET_TIMEOUT / rig.realtime_factor + SLACK
    )
    # The robot stays stopped while the link is stalled (the timer still "sends" each 100 ms).
    now = rig.daemon.now
    rig.wait(lambda: rig.daemon.now > now + 2.0, 5.0, "2 s of robot time")
    assert stopped() and rig.daemon.stack.last_output.source != "Tablet"
    assert rig.backend.sim.true_velocity() == (0.0, 0.0)
    # Missing pongs make the Tablet warn that commands will not be obeyed.
    rig.wait(lambda: not screen.warning_label.isHidden(), 5.0, "the lossy-link warning")

    # The link recovers: the finger still on the joystick drives again, release stops.
    monkeypatch.undo()
    rig.wait(tablet_drives, 5.0, "teleoperation to resume after the stall")
    rig.touch(joystick, device, "release", point)
    rig.wait(stopped, 5.0, "the robot to stop on release")
