"""The station's mirror of the robot's route: the robot owns it, the station only reflects it.

shared/DESIGN.md, "State has one owner": the robot (its navigator) owns the route, its id, its
progress and its end; the station sends *requests* and mirrors the answers. So the station never
re-sends a route it only remembers. After the link comes back (a zenoh drop, a robot restart, a
station that selected the robot again) it *asks* (the ``state`` query and the robot's periodic
``route_progress``, which says ``idle`` when the robot has no route) and acts on the answer:

* the robot still drives our route: keep mirroring it;
* the robot finished it while we were away: its verdict settles the task (the caller's job);
* the robot has another route, or none (it restarted): our route is **lost** - the task ends
  with that reason, nothing is re-sent (a restarted robot never resumes without an operator);
* the robot says nothing within ``answer_timeout``: lost as well (never assume it drives).

A route the robot drives that this station did not start (the station restarted mid-route) is
**foreign**: the station shows it, and a stop from the operator or the tablet cancels it.
Pure: time is passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

from interbot_core.topics import RouteProgress

RUNNING_STATES = ("active", "paused")


@dataclass(frozen=True)
class RouteLost:
    """Our route is gone on the robot; ``reason`` says why (for the operator and the task)."""

    route_id: int
    reason: str


class RouteMirror:
    """What the station knows of the robot's route (see the module docstring)."""

    def __init__(self, answer_timeout: float = 5.0) -> None:
        self.answer_timeout = answer_timeout  # [s]
        self.route_id: int | None = None  # the route this station started and still mirrors
        self.foreign: RouteProgress | None = None  # a running route this station did not start
        self.last: RouteProgress | None = None  # the robot's last word
        self._asked_at: float | None = None  # a check after a reconnect is pending since then

    @property
    def checking(self) -> bool:
        """True while the station waits for the robot's answer after a reconnect."""
        return self._asked_at is not None

    def started(self, route_id: int) -> None:
        """This station sent route ``route_id`` (and a robot received it)."""
        self.route_id = route_id
        self._asked_at = None
        self.foreign = None

    def ended(self) -> None:
        """The route is over for the station (finished, cancelled, lost)."""
        self.route_id = None
        self._asked_at = None

    def reconnected(self, now: float) -> None:
        """The link to the robot is back (or another robot selected): ask before believing."""
        self.last = None
        self.foreign = None
        if self.route_id is not None:
            self._asked_at = now

    def on_progress(self, progress: RouteProgress) -> RouteLost | None:
        """The robot's report; returns `RouteLost` when it shows that our route is gone."""
        self.last = progress
        running = progress.state in RUNNING_STATES
        if progress.route_id == self.route_id and self.route_id is not None:
            self._asked_at = None
            self.foreign = None
            return None
        if self.route_id is None:
            self.foreign = progress if running else None
            return None
        if not self.checking:
            return None  # a late report of an older route, sent before ours arrived
        lost_id = self.route_id
        self.ended()
        self.foreign = progress if running else None
        if progress.state == "idle":
            why = "the robot has no route (it restarted?); not re-sent without an operator"
        else:
            why = f"the robot now has route {progress.route_id} ({progress.state})"
        return RouteLost(lost_id, f"route {lost_id} lost: {why}")

    def check_timeout(self, now: float) -> RouteLost | None:
        """`RouteLost` when the robot has not answered within ``answer_timeout``."""
        if self._asked_at is None or self.route_id is None:
            return None
        if now - self._asked_at <= self.answer_timeout:
            return None
        lost_id = self.route_id
        self.ended()
        return RouteLost(
            lost_id,
            f"route {lost_id} lost: the robot did not report it within "
            f"{self.answer_timeout:g} s of reconnecting; not re-sent",
        )

    @property
    def robot_running(self) -> bool:
        """The robot's last word is a route in progress (ours or not)."""
        return self.last is not None and self.last.state in RUNNING_STATES
