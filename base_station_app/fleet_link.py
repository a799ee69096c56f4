"""What the station sends its robots, and what each robot must hear until it has (issue 13).

The selected robot is reached through the `StationLink` (which follows it closely), every other
robot through the `FleetWatch`. Some state must *arrive*, not merely be sent once: the
operator's stop intent, the planner configuration and the station's assisted-teleoperation
flag. Each `RobotMirror` keeps a pending flag for each; `resend_pending` sends what is pending
and clears a flag only when a robot's subscriber matched, so a robot not linked yet, or
restarted, hears it at the next clock.

The operator's stop (issue 11) is owned here, for the whole fleet: while it is engaged it is
sent to every robot, and re-sent to one that reports no stop (`check_stop`); once released, a
robot's start latch is released only if the operator has commanded (selected) it from this
station. ``estop_latched`` is read by the tablet thread; the controller writes it under the
tablet speed path's lock.

`send` is also called in the tablet thread (the tablet's speed, under that lock): ``log`` must
be safe to call from there. Plain Python: the controller owns the Qt timers and calls in.
"""

from __future__ import annotations

from collections.abc import Callable

from base_station_app.fleet import Fleet
from base_station_app.robot_mirror import RobotMirror
from interbot_core.topics import AssistMsg, ConfigMsg, Lock, StopRelease, Topic
from interbot_link import LinkError, StationLink
from interbot_link.command_priority import ZENOH_SEND_THREADS, NamedThreadRaiser
from interbot_link.fleet_watch import FleetWatch

#: [s] while the operator's stop is engaged and a robot reports none, re-send it this often.
STOP_REASSERT_S = 0.5


class FleetLink:
    """Sending to the fleet's robots and the must-arrive state (see the module docstring)."""

    def __init__(
        self,
        link: StationLink | None,
        watch: FleetWatch | None,
        fleet: Fleet,
        clock: Callable[[], float],
        log: Callable[[str, str], None],
        config: ConfigMsg,
    ) -> None:
        self.link, self.watch, self._fleet, self._clock, self._log = link, watch, fleet, clock, log
        self.config = config  # the planner parameters every robot must hear
        self.assist = False  # the station's assisted teleoperation, likewise
        self.estop_latched = False  # the operator's stop, for every robot
        self.closed = False  # after shutdown nothing is sent
        # zenoh's transmit threads send the tablet's commands (issue 14): at the tablet
        # thread's priority. Only those: its receiving threads bring display data (scans,
        # poses), and at real-time priority they ran it ahead of the tablet's commands (A/B,
        # 3 pairs at load 10-11: p99 6.4, 10.1, 5.6 ms with them, 3.7, 5.2, 3.1 ms without).
        self.network_threads = NamedThreadRaiser("the station's zenoh threads", ZENOH_SEND_THREADS)

    @property
    def robot_online(self) -> bool:
        """Whether the selected robot is present (the tablet thread reads it: see the lock)."""
        selected = self.link is not None and self.link.selected is not None
        return selected and self._fleet.selected.online

    def send(self, topic: Topic, message: object) -> bool:
        """Send to the selected robot (False: nobody received it)."""
        link = self.link
        if link is None or link.selected is None or self.closed:
            return False
        try:
            return link.send(topic, message)
        except LinkError as exc:
            self._log("error", f"cannot send {topic}: {exc}")
            return False

    def send_to(self, mirror: RobotMirror, topic: Topic, message: object) -> bool:
        """Send to ``mirror``'s robot: the selected one through the link, others watched."""
        if mirror is self._fleet.selected:
            return self.send(topic, message)
        robot_id, watch = mirror.robot_id, self.watch
        if robot_id is None or watch is None or self.closed or robot_id not in watch.watched:
            return False
        try:
            return watch.send(robot_id, topic, message)
        except LinkError as exc:
            self._log("error", self._fleet.about(mirror, f"cannot send {topic}: {exc}"))
            return False

    def sync_watch(self) -> None:
        """Watch every robot seen except the selected one (followed by the link)."""
        if self.watch is not None and self.link is not None and not self.closed:
            self.watch.set_watched(set(self._fleet.mirrors) - {self.link.selected or ""})

    def resend_pending(self, mirror: RobotMirror) -> None:
        """Must-arrive state that found no subscriber (robot not yet linked, or restarted)."""
        if mirror.stop_assert_pending:
            self.assert_stop_intent(mirror)
        if mirror.config_pending:
            mirror.config_pending = not self.send_to(mirror, Topic.CONFIG, self.config)
        if mirror.assist_pending:
            msg = AssistMsg("station_vel", self.assist, stamp=self._clock())
            mirror.assist_pending = not self.send_to(mirror, Topic.TELEOP_ASSIST, msg)

    def set_config(self, config: ConfigMsg) -> None:
        """New planner parameters: every robot must hear them."""
        self.config = config
        for mirror in self._fleet.all():
            mirror.config_pending = True
            self.resend_pending(mirror)

    def set_assist(self, enabled: bool) -> None:
        """The station's assisted teleoperation on/off (issue 17): every robot must hear it."""
        if enabled == self.assist:
            return
        self.assist = enabled
        self._log("info", f"assisted driving {'on' if enabled else 'off'} for the Base Station")
        for mirror in self._fleet.all():
            mirror.assist_pending = True
            self.resend_pending(mirror)

    def assert_stop_intent(self, mirror: RobotMirror) -> None:
        """Tell a robot the operator's stop: engaged (re-sent) or released (its start latch)."""
        now = self._clock()
        if not self.estop_latched and not mirror.commanded and mirror.robot_id is not None:
            # Never commanded from here: its start latch stays until the operator selects it.
            mirror.stop_assert_pending = False
            return
        if self.estop_latched:
            delivered = self.send_to(mirror, Topic.STOP, Lock(True, stamp=now))
        else:
            delivered = self.send_to(mirror, Topic.STOP, Lock(False, stamp=now)) and self.send_to(
                mirror, Topic.STOP_RELEASE, StopRelease("base station (on connection)", stamp=now)
            )
        mirror.stop_sent_at = now
        mirror.stop_assert_pending = not delivered

    def check_stop(self, now: float, mirror: RobotMirror) -> None:
        """The operator's stop is engaged but a robot reports none: say it again."""
        if (
            self.estop_latched
            and mirror.state.estop_engaged is False
            and now - mirror.stop_sent_at >= STOP_REASSERT_S
        ):
            again = "the robot reports no emergency stop: sending it again"
            self._log("warning", self._fleet.about(mirror, again))
            self.assert_stop_intent(mirror)

    def raise_network_threads(self) -> None:
        """zenoh's transmit threads to real-time priority as they appear; the first outcome is
        logged where the operator sees it (a refusal as a warning)."""
        outcome = self.network_threads.scan()
        if outcome is not None:
            self._log("info" if outcome.realtime else "warning", outcome.text)

    def close(self) -> None:
        """Nothing is sent from now on; the watch and the link are closed."""
        self.closed = True
        if self.watch is not None:
            self.watch.close()
        if self.link is not None:
            self.link.close()
