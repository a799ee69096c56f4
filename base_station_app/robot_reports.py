"""What the robots say, into the station's mirror of each (issue 14: per-robot supervision).

Each frame the station polls its link: liveliness events, the selected robot's state (the
newest value of each topic, decoded only for a frame that is drawn) and the watched robots'
light state and events. A robot that appears is marked online, watched, and asked its state
(its route: never assumed after a restart); one that leaves is marked offline and raises an
alert. Every message goes into its robot's `RobotMirror`, past the alert rules; a route the
robot lost, its status lines and its progress go to `SupervisorEvents`.

A robot's online flag gates the tablet's speed path, so it is written under that path's
``lock`` (tablet_teleop.py). Plain Python: the controller calls `poll` from its frame timer.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from base_station_app.alerts import AlertRules
from base_station_app.fleet import Fleet
from base_station_app.fleet_link import FleetLink
from base_station_app.supervisor_events import SupervisorEvents
from interbot_link import RobotAppeared, RobotLeft, StateMessage


class RobotReports:
    """Turns what the robots send into their mirrors' state (see the module docstring)."""

    def __init__(
        self,
        fleet: Fleet,
        robot_link: FleetLink,
        events: SupervisorEvents,
        alert_rules: AlertRules,
        lock: threading.RLock,
        log: Callable[[str, str], None],
        robots_changed: Callable[[], object],
        clock: Callable[[], float],
    ) -> None:
        self._fleet, self._link = fleet, robot_link
        self._events, self._alert_rules = events, alert_rules
        self.lock = lock  # the tablet speed path's: it reads a robot's ``online``
        self._log, self._robots_changed, self._clock = log, robots_changed, clock

    def poll(self, display: bool) -> None:
        """Link events, the selected robot's newest state (``display``: a frame is drawn), the
        watched robots' messages, then every robot's progress on its route.

        Between frames only the events are taken: the state topics wait in their rings of one,
        so only the newest scan / pose is decoded, once per frame (issue 14).
        """
        link = self._link.link
        if link is None:
            return
        for event in link.poll_events():
            if isinstance(event, RobotAppeared):
                self._appeared(event.robot_id)
                link.request_state(event.robot_id)  # its route (a restart?): never assume
            elif isinstance(event, RobotLeft):
                self._left(event.robot_id)
            elif isinstance(event, StateMessage):
                self._on_state_message(event)
        selected = self._fleet.selected
        for topic, message in (link.poll_state() if display else {}).items():
            selected.state.apply(topic, message)
            self._alert_rules.on_message(selected.robot_id or "?", message, self._clock())
        if self._link.watch is not None:
            for msg in self._link.watch.poll():
                self._on_state_message(msg)
        for mirror in self._fleet.all():
            self._events.robot_progress(mirror)

    def _appeared(self, robot_id: str) -> None:
        mirror = self._fleet.mirror(robot_id)
        with self.lock:
            mirror.online = True
        self._log("info", f"robot {robot_id} is online")
        self._link.sync_watch()
        mirror.connected(self._clock())
        self._robots_changed()

    def _left(self, robot_id: str) -> None:
        mirror = self._fleet.mirror(robot_id)
        with self.lock:
            mirror.online = False
        self._log("error", f"robot {robot_id} lost (liveliness token gone)")
        self._alert_rules.on_robot_left(robot_id, self._clock())
        self._robots_changed()

    def _on_state_message(self, event: StateMessage) -> None:
        """A message from one robot (the link's or the watch's): into that robot's mirror."""
        mirror = self._fleet.mirrors.get(event.robot_id)
        if mirror is None:
            return  # a robot never announced: nothing to mirror it into
        lost, lines = mirror.on_message(event.topic, event.message)
        self._alert_rules.on_message(mirror.robot_id or "?", event.message, self._clock())
        if lost is not None:
            self._events.route_lost(lost, mirror)
        for status in lines:
            self._events.log_for(mirror, status.level, f"robot: {status.text}")
