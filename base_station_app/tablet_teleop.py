"""The tablet's speed commands, from its socket to the robot, off the drawing thread (issue 14).

The station's Qt thread draws the map (a few ms per frame); a speed command that arrived while
a frame was drawn used to wait for it. `TabletTeleop` lives in the tablet thread with the
`TabletServer` that reads the tablet's socket, and forwards each speed command from there the
moment it is decoded: permission and e-stop check, `TeleopArbiter` (freshness, watchdog), the
zenoh publisher. The Qt thread hears about it afterwards through queued signals (log lines,
alerts, the tablet panel), never on the command's path.

One owner, one lock. The arbiter's tablet state and the sending of ``tablet_vel`` are guarded
by ``lock``; the station takes the same lock to change what gates the tablet (the e-stop and
the selected robot: the controller; the permissions: `TabletLink`; whether a robot is online:
`RobotReports`; everything the refusal check reads) and to stop the tablet's driving. So:

* **the e-stop wins**: once the controller has latched it under the lock, no speed command is
  forwarded; one forwarded just before is followed by the explicit zero (likewise a withdrawn
  permission);
* **no command lost or reordered**: commands are forwarded one at a time, in arrival order, by
  one thread;
* **a stalled tablet gets its zero**: the watchdog is a single-shot `QTimer` in the tablet
  thread (thesis Fig. 5.10), restarted by every forwarded command, so it fires on time even
  while the Qt thread draws.

Whoever holds ``lock`` never waits for the tablet thread (no blocking call inside it), so the
tablet thread's use of it cannot deadlock.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from PySide6.QtCore import QObject, Qt, QTimer, Signal

from base_station_app.fleet_link import FleetLink
from base_station_app.tablet_policy import TabletPolicy
from base_station_app.teleop_arbiter import Forward, Refuse, TeleopArbiter
from interbot_core import protocol as p
from interbot_core.topics import Twist

logger = logging.getLogger(__name__)

Clock = Callable[[], float]


class TabletTeleop(QObject):
    """Forwards the tablet's speed commands in the thread it lives in (see the module docstring).

    ``send_twist(twist)`` publishes on the selected robot's ``tablet_vel`` (False: nobody
    received it); ``robot_link`` says whether that robot is online and the operator's stop
    latched, and with ``policy`` why teleoperation is refused now (permission withdrawn, robot
    offline, e-stop); ``reply(msg)`` sends a message to the tablet (called in this object's
    thread).

    Signals (queued to the Qt thread): ``refused(reason)`` a speed refused (said to the tablet
    once per stream), ``stopped(why)`` the tablet's driving stopped with an explicit zero,
    ``forwarded()`` a command went to the robot.
    """

    refused = Signal(str)
    stopped = Signal(str)
    forwarded = Signal()
    _watchdog_start_requested = Signal()

    def __init__(
        self,
        arbiter: TeleopArbiter,
        clock: Clock,
        robot_link: FleetLink,
        policy: TabletPolicy,
        send_twist: Callable[[Twist], bool],
        reply: Callable[[p.StationMessage], object],
        latency_ceiling: float,
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self.arbiter = arbiter
        self.lock = threading.RLock()
        self._clock = clock
        self._link, self._policy, self._send_twist = robot_link, policy, send_twist
        self._reply = reply
        # Thesis Fig. 5.10: a single-shot timer restarted by every forwarded command; its
        # timeout means the tablet went silent for the latency ceiling: one explicit zero.
        self.watchdog = QTimer(self)
        self.watchdog.setSingleShot(True)
        self.watchdog.setTimerType(Qt.TimerType.PreciseTimer)
        self.watchdog.setInterval(round(latency_ceiling * 1000))
        self.watchdog.timeout.connect(self.on_watchdog)
        # Started from another thread (a test driving the controller) it is queued to ours.
        self._watchdog_start_requested.connect(self.watchdog.start)
        self.ceiling_s = latency_ceiling

    def set_ceiling(self, latency_ceiling: float) -> None:
        """The watchdog's period [s]; applied by the tablet thread (the timer is its)."""
        self.ceiling_s = latency_ceiling
        ms = round(latency_ceiling * 1000)
        QTimer.singleShot(0, self, lambda: self.watchdog.setInterval(ms))

    # ------------------------------------------------------------------ the command path
    def on_speed(self, msg: p.Speed) -> None:
        """One validated speed command from the tablet, at its arrival (tablet thread)."""
        now = self._clock()
        verdict: Forward | Refuse | None = None
        with self.lock:
            link = self._link
            why = self._policy.refusal("teleop", link.robot_online, link.estop_latched)
            if why is not None:  # said to the tablet once per stream (and reason)
                tell = self.arbiter.tell(why)
            else:
                verdict = self.arbiter.on_tablet_speed(msg, now, link.estop_latched)
                if isinstance(verdict, Forward):
                    self._send_twist(verdict.twist)
        if why is not None:
            if tell:
                self._reply(p.ErrorReport("not_permitted", why))
            self.refused.emit(why)
        elif isinstance(verdict, Forward):
            self._watchdog_start_requested.emit()
            self.forwarded.emit()
        elif isinstance(verdict, Refuse):
            self._reply(p.ErrorReport("not_permitted", verdict.reason))
            self.refused.emit(verdict.reason)

    def stop(self, why: str, then: Callable[[], object] | None = None) -> bool:
        """Forget the tablet's command; one explicit zero if one was forwarded (any thread).

        ``then`` runs under the same hold of the lock, after the zero (a robot switch: no
        command can reach the old robot between its zero and the switch). The watchdog may
        still fire later: it then finds nothing forwarded and sends nothing.
        """
        with self.lock:
            zero = self.arbiter.stop_tablet()
            if zero:
                self._send_twist(Twist(0.0, 0.0, stamp=self._clock()))
            if then is not None:
                then()
        if zero:
            self.stopped.emit(why)
        return zero

    def on_tablet_disconnected(self) -> None:
        """The tablet is gone: its driving stops now, in this thread, not when the Qt thread
        gets to it."""
        self.stop("tablet disconnected")

    def on_watchdog(self) -> None:
        """Thesis Fig. 5.10: no speed command for the latency ceiling (§5.3.4)."""
        self.stop(f"no command for {self.ceiling_s:g} s")
