"""Who drives the commanded robot by hand, and with which command (issue 11 "fresh commands").

Two sources teleoperate (thesis §5.3.4): the station's own keys/pad/mouse joystick
(`TeleopInput`, repeated by the clock while held) and the tablet's joystick, whose commands are
forwarded **once**, on arrival, stamped with the arrival time. `TeleopArbiter` decides, without
Qt and without sending anything itself, what each input means:

* a tablet command is checked (`SpeedFreshness`: out-of-order or late ones are dropped) and, if
  fresh, forwarded; during an emergency stop it is refused (the tablet is told once per stream);
* stopping the tablet's driving (watchdog timeout, stop, disconnect, permission withdrawn)
  yields one explicit zero if a command was forwarded, none otherwise;
* the station's keys produce their command while held, one zero on release, nothing during a
  stop.

`TabletTeleop` (tablet_teleop.py) owns the single-shot watchdog `QTimer` (thesis Fig. 5.10) and
sends what the arbiter returns for the tablet to the *selected* robot, in the tablet thread; the
arbiter's tablet state is used under its lock (issue 14). The controller sends the keys'.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from base_station_app.teleop import TeleopInput
from interbot_core import protocol as p
from interbot_core.speed_freshness import SpeedFreshness
from interbot_core.topics import Twist
from interbot_core.watchdog import LatencyWatchdog, PeriodStats

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Forward:
    """Forward this tablet command now and (re)start the watchdog."""

    twist: Twist


@dataclass(frozen=True)
class Refuse:
    """Tell the tablet why its speed is refused (said once per stream)."""

    reason: str


SpeedVerdict = Forward | Refuse | None  # None: dropped silently (stale, or already told)


class TeleopArbiter:
    """State of both teleoperation sources (see the module docstring)."""

    def __init__(self, latency_ceiling: float, linear_max: float, angular_max: float) -> None:
        self.keys = TeleopInput(linear_max, angular_max)
        self.watchdog = LatencyWatchdog(latency_ceiling)  # latency shown to the operator
        self.freshness = SpeedFreshness(latency_ceiling)
        self.tablet_periods = PeriodStats(5000)
        self.tablet_speed: p.Speed | None = None
        self.tablet_forwarding = False
        self.tablet_discarded = 0
        self.told: str | None = None  # why its speed is refused, as the tablet was told
        self._keys_were_active = False

    def set_limits(self, latency_ceiling: float, linear_max: float, angular_max: float) -> None:
        self.keys.set_limits(linear_max, angular_max)
        self.watchdog.ceiling_s = latency_ceiling
        self.freshness.ceiling_s = latency_ceiling

    # ------------------------------------------------------------------ the tablet
    def tablet_connected(self) -> None:
        self.watchdog.reset()
        self.freshness.reset()
        self.told = None

    def tell(self, reason: str) -> bool:
        """Whether the tablet must be told ``reason`` for a refused speed: once per stream of
        refused speeds, again when the reason changes or after driving resumed. Decided with
        the refusal, under the speed path's lock: a refusal that raced a change of what gates
        the tablet (a permission withdrawn while its new permissions are sent) is not told
        twice."""
        if self.told == reason:
            return False
        self.told = reason
        return True

    def on_tablet_speed(self, msg: p.Speed, now: float, stopped: bool) -> SpeedVerdict:
        """One tablet speed command arriving at ``now``; ``stopped``: the e-stop is latched."""
        self.watchdog.feed(now)
        self.tablet_periods.add_arrival(now)
        if stopped:
            reason = "emergency stop engaged: speed ignored"
            return Refuse(reason) if self.tell(reason) else None
        verdict = self.freshness.check(msg.seq, msg.t, now)
        if not verdict.fresh:
            self.tablet_discarded += 1
            logger.info("tablet speed dropped: %s", verdict.reason)
            return None
        self.tablet_speed = msg
        self.tablet_forwarding = True
        self.told = None  # driving again: the next refusal starts a new stream
        return Forward(Twist(msg.linear, msg.angular, stamp=now))

    def stop_tablet(self) -> bool:
        """Forget the tablet's command; True when one explicit zero must be sent."""
        self.tablet_speed = None
        if not self.tablet_forwarding:
            return False
        self.tablet_forwarding = False
        self.tablet_discarded += 1
        return True

    # ------------------------------------------------------------------ the station's keys
    def keys_command(self, stopped: bool) -> tuple[float, float] | None:
        """The held command to repeat, or None (nothing held, or the stop is latched)."""
        return self.keys.command() if self.keys.active and not stopped else None

    def keys_changed(self, stopped: bool) -> tuple[float, float] | None:
        """After a change: the command to send at once, (0, 0) once on release, else None."""
        command = self.keys_command(stopped)
        if command is None and self._keys_were_active:
            command = (0.0, 0.0)
        self._keys_were_active = self.keys.active
        return command
