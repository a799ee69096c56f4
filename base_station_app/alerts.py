"""Alerts: what an operator must see and acknowledge, not a line lost in the status log.

`AlertList` keeps the alerts of every robot: time, robot, kind, text, how many times it happened,
and whether the operator has acknowledged it. The same condition on the same robot raises one
alert that counts repeats (a route blocked ten times is one row, "×10"), until it is
acknowledged; then a new occurrence is a new alert. `AlertRules` turns what the station already
receives into alerts, each rule on a transition so a condition that persists is raised once:

* ``collision``: the robot reports a contact (its motors stalled against something; the daemon's
  ``status`` line starts with "collision:");
* ``fault``: a device fault reported by the robot ("fault:");
* ``blocked``: the robot aborted a route (``route_progress`` state ``aborted``);
* ``lost``: localisation went from ``ok`` to ``lost``;
* ``battery``: state of charge fell below `LOW_BATTERY` (again only after it rose above
  `BATTERY_RECOVERED`);
* ``offline``: the robot's liveliness token went (clean exit, crash or lease expiry);
* ``malfunction``: someone reported a malfunction at the tablet;
* ``refused``: a tablet command was refused (permissions, the stop), once per reason a minute.

Qt-free: every call takes ``now`` [s] (the station's monotonic clock); the wall-clock time shown
beside an alert comes from an injected ``wall_clock``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from interbot_core.topics import Battery, PoseMsg, RouteProgress, Status

LOW_BATTERY = 0.20  # state of charge
BATTERY_RECOVERED = 0.25
REFUSED_REPEAT_S = 60.0  # [s] the same refusal is one alert per minute
KINDS = (
    "collision",
    "fault",
    "blocked",
    "lost",
    "battery",
    "offline",
    "malfunction",
    "refused",
    "waiting",  # a robot the operator does not command waits for them (request, tour stop)
)
SEVERE = frozenset({"collision", "fault", "blocked", "lost", "offline"})


@dataclass(frozen=True)
class Alert:
    id: int
    kind: str  # one of KINDS
    robot: str  # robot id, or "tablet"
    text: str
    first: float  # [s] station clock
    last: float
    count: int = 1
    acknowledged: bool = False
    last_wall: float = 0.0  # [s since the epoch] for the operator

    @property
    def severe(self) -> bool:
        return self.kind in SEVERE


@dataclass
class AlertList:
    """Every alert of this station session, newest last; ``version`` grows on each change."""

    alerts: list[Alert] = field(default_factory=list)
    version: int = 0
    wall_clock: Callable[[], float] = time.time
    _next_id: int = 1
    _listeners: list[Callable[[Alert], None]] = field(default_factory=list)

    def subscribe(self, listener: Callable[[Alert], None]) -> None:
        """``listener(alert)`` on every new alert or repeat (for the badge, the sound)."""
        self._listeners.append(listener)

    def raise_alert(self, kind: str, robot: str, text: str, now: float) -> Alert:
        if kind not in KINDS:
            raise ValueError(f"alert kind {kind!r} is not one of {list(KINDS)}")
        for i, alert in enumerate(self.alerts):
            same = (alert.kind, alert.robot, alert.text) == (kind, robot, text)
            if same and not alert.acknowledged:
                self.alerts[i] = replace(
                    alert, last=now, count=alert.count + 1, last_wall=self.wall_clock()
                )
                return self._changed(self.alerts[i])
        alert = Alert(self._next_id, kind, robot, text, now, now, last_wall=self.wall_clock())
        self._next_id += 1
        self.alerts.append(alert)
        return self._changed(alert)

    def _changed(self, alert: Alert) -> Alert:
        self.version += 1
        for listener in list(self._listeners):
            listener(alert)
        return alert

    def acknowledge(self, alert_id: int) -> None:
        for i, alert in enumerate(self.alerts):
            if alert.id == alert_id and not alert.acknowledged:
                self.alerts[i] = replace(alert, acknowledged=True)
                self.version += 1

    def acknowledge_all(self) -> None:
        if any(not a.acknowledged for a in self.alerts):
            self.alerts = [replace(a, acknowledged=True) for a in self.alerts]
            self.version += 1

    @property
    def unacknowledged(self) -> list[Alert]:
        return [a for a in self.alerts if not a.acknowledged]


@dataclass
class _RobotMemory:
    localisation: str = "unset"
    battery_low: bool = False
    aborted: set[int] = field(default_factory=set)


class AlertRules:
    """Raises alerts on `AlertList` from the messages the station receives (see module doc)."""

    def __init__(self, alerts: AlertList) -> None:
        self.alerts = alerts
        self._robots: dict[str, _RobotMemory] = {}
        self._refused_at: dict[str, float] = {}

    def _memory(self, robot: str) -> _RobotMemory:
        return self._robots.setdefault(robot, _RobotMemory())

    def on_message(self, robot: str, message: object, now: float) -> None:
        """Any message from ``robot``: the rules that apply to its kind."""
        if isinstance(message, PoseMsg):
            self.on_pose(robot, message, now)
        elif isinstance(message, Battery):
            self.on_battery(robot, message, now)
        elif isinstance(message, RouteProgress):
            self.on_route_progress(robot, message, now)
        elif isinstance(message, Status):
            self.on_status(robot, message, now)

    def on_pose(self, robot: str, pose: PoseMsg, now: float) -> None:
        memory = self._memory(robot)
        if pose.state == "lost" and memory.localisation == "ok":
            self.alerts.raise_alert("lost", robot, "localisation lost: the robot has stopped", now)
        memory.localisation = pose.state

    def on_battery(self, robot: str, battery: Battery, now: float) -> None:
        memory = self._memory(robot)
        if battery.soc < LOW_BATTERY and not memory.battery_low:
            memory.battery_low = True
            text = f"battery low: {battery.soc * 100:.0f} % ({battery.voltage:.1f} V)"
            self.alerts.raise_alert("battery", robot, text, now)
        elif battery.soc > BATTERY_RECOVERED:
            memory.battery_low = False

    def on_route_progress(self, robot: str, progress: RouteProgress, now: float) -> None:
        memory = self._memory(robot)
        if progress.state == "aborted" and progress.route_id not in memory.aborted:
            memory.aborted.add(progress.route_id)
            reason = progress.reason or "no reason given"
            self.alerts.raise_alert("blocked", robot, f"route aborted: {reason}", now)

    def on_status(self, robot: str, status: Status, now: float) -> None:
        text = status.text
        for prefix, kind in (("collision:", "collision"), ("fault:", "fault")):
            if text.startswith(prefix):
                self.alerts.raise_alert(kind, robot, text.removeprefix(prefix).strip(), now)

    def on_robot_left(self, robot: str, now: float) -> None:
        self.alerts.raise_alert("offline", robot, "the robot went offline", now)
        self._memory(robot).localisation = "unset"

    def on_malfunction(self, kind: str, text: str, now: float) -> None:
        words = kind.replace("_", " ")
        self.alerts.raise_alert(
            "malfunction",
            "tablet",
            f"reported at the tablet: {words}" + (f": {text}" if text else ""),
            now,
        )

    def on_refused(self, reason: str, now: float) -> None:
        last = self._refused_at.get(reason)
        if last is not None and now - last < REFUSED_REPEAT_S:
            return
        self._refused_at[reason] = now
        self.alerts.raise_alert("refused", "tablet", f"tablet command refused: {reason}", now)
