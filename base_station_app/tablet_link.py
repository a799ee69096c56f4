"""The tablet as the station's Qt thread sees it: its connection, what it is told, its requests.

The tablet server and its speed path (`TabletServer`, `TabletTeleop`) run in the tablet thread;
their signals arrive here queued. This object turns them into what the operator sees (log lines,
alerts, the tablet panel's ``changed``) and keeps what the tablet was told: its permissions
(sent again only when they change: what the operator allows and only what can work, nothing
while the robot is offline or the stop is engaged) and, each ``clock()``, the commanded robot's
pose, goal, tour and status (`TabletFeed`, thesis §5.3.2). A validated request goes to
`TabletRequests`.

What gates the tablet's speed path (permissions, here) is written under ``teleop.lock``, as
the controller writes the e-stop and `RobotReports` a robot's online flag
(tests/test_architecture.py).
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import QObject, Signal

from base_station_app.alerts import AlertRules
from base_station_app.fleet import Fleet
from base_station_app.fleet_link import FleetLink
from base_station_app.tablet_feed import TabletFeed
from base_station_app.tablet_policy import TabletPolicy, with_kind
from base_station_app.tablet_requests import TabletRequests
from base_station_app.tablet_server import TabletServer
from base_station_app.tablet_teleop import TabletTeleop
from interbot_core import protocol as p


class TabletLink(QObject):
    """The tablet's connection on the station's Qt thread (see the module docstring)."""

    changed = Signal()  # connection, permissions, its task, its driving: the panel redraws

    def __init__(
        self,
        server: TabletServer,
        teleop: TabletTeleop,
        requests: TabletRequests,
        fleet: Fleet,
        robot_link: FleetLink,
        alert_rules: AlertRules,
        names: dict[int, str],
        log: Callable[[str, str], None],
        clock: Callable[[], float],
        parent: QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self.server, self.teleop, self.requests = server, teleop, requests
        self.policy: TabletPolicy = requests.policy
        self.feed = TabletFeed()
        self.permissions_sent: p.Permissions | None = None
        self._fleet, self._link, self._alert_rules = fleet, robot_link, alert_rules
        self._names, self._log, self._clock = names, log, clock
        server.connected.connect(self.on_connected)
        server.disconnected.connect(self.on_disconnected)
        server.message_received.connect(self.on_message)
        server.latency_measured.connect(self.changed)
        server.protocol_error.connect(lambda text: log("warning", f"tablet: {text}"))
        server.refused.connect(self.log_refused)
        teleop.refused.connect(self.on_speed_refused)
        teleop.stopped.connect(self.on_speed_stopped)
        teleop.forwarded.connect(self.changed)

    def start(self) -> bool:
        """The tablet server's thread (its priority said), then listen; False: port taken."""
        self.server.start_thread()
        priority = self.server.priority
        if priority is not None:  # the tablet's commands: real-time or not
            self._log("info" if priority.realtime else "warning", priority.text)
        ok = self.server.listen()
        if not ok:
            self._log("error", f"cannot listen for the tablet on port {self.server.port}")
        return ok

    def on_connected(self, peer: str) -> None:
        self.feed.forget()
        with self.teleop.lock:
            self.teleop.arbiter.tablet_connected()
        self.permissions_sent = None
        self.send_permissions()
        self._log("info", f"tablet connected from {peer}")
        self.changed.emit()

    def on_disconnected(self) -> None:
        self.teleop.stop("tablet disconnected")
        with self.teleop.lock:
            self.teleop.arbiter.watchdog.reset()
        self._log("warning", "tablet disconnected")
        self.changed.emit()

    def on_message(self, msg: p.TabletMessage) -> None:
        """A validated request (tablet_requests.py); speed commands never come this way: they
        are forwarded in the tablet thread (tablet_teleop.py)."""
        self.requests.on_message(msg)
        self.changed.emit()

    def on_speed_refused(self, why: str) -> None:
        self._alert_rules.on_refused(why, self._clock())
        self.changed.emit()

    def on_speed_stopped(self, why: str) -> None:
        self._log("warning", f"tablet speed stopped ({why}): explicit zero sent")
        self.changed.emit()

    def log_refused(self, peer: str, why: str) -> None:
        """A tablet connection refused (another is connected, TLS, pairing)."""
        self._log("warning", f"refused tablet {peer}: {why}")

    def log_authorised(self, record: object) -> None:
        tablet_id, name = getattr(record, "tablet_id", "?"), getattr(record, "name", "?")
        self._log("info", f"tablet {tablet_id} ({name}) authorised")

    def set_permission(self, kind: str, allowed: bool) -> None:
        """The operator allows or forbids a kind of request; withdrawn teleop stops at once."""
        with self.teleop.lock:  # the tablet thread reads it (TabletTeleop.on_speed)
            self.policy.permissions = with_kind(self.policy.permissions, kind, allowed)
            if not self.policy.permissions.teleop:
                self.teleop.stop("teleoperation not permitted")
        self.send_permissions()
        self._log("info", f"tablet {kind} {'allowed' if allowed else 'forbidden'}")
        self.changed.emit()

    def send_permissions(self) -> None:
        """What the tablet may do now: the operator's choice, and only what can work."""
        msg = self.policy.effective(self._link.robot_online, self._link.estop_latched)
        if msg != self.permissions_sent and self.server.send(msg):
            self.permissions_sent = msg

    def communicate(self, now: float) -> None:
        """The clock's communication section: tell the tablet about the commanded robot."""
        if not self.server.is_connected:
            return
        self.send_permissions()
        robot, estop = self._fleet.selected, self._link.estop_latched
        status = p.StatusInfo(robot.task_text(self._names), robot.status_text(estop))
        for message in self.feed.messages(robot, now, self._link.robot_online, status):
            self.server.send(message)
