"""The Base Station's policy for the one controlling Tablet (thesis §5.3 "Tablet Control", §5.3.1).

The thesis lets the station operator decide "if the requests from the Tablet should be accepted
or not, and which type of requests are allowed": the four kinds of the protocol's `Permissions`
(teleoperation, goals, tours, requests). `permission_for` names the kind a tablet message needs; safety messages (pause, stop), the "Help me!" initial pose, malfunction reports and the
connection housekeeping (hello, ping, pong, error) need none. `ErrorBudget` is the rule for
closing a misbehaving connection: a frame that is too large closes it at once, otherwise more
than ``max_errors`` protocol errors within ``window_s`` seconds do.
"""

from __future__ import annotations

import logging
from collections import deque

from interbot_core.protocol import (
    Goal,
    Home,
    RequestAnswer,
    RequestFrom,
    Speed,
    TabletMessage,
    Tour,
    TourControl,
)
from interbot_core.supervisor import Delivery, GoHome, GoTo, GoToPose, GuidedTour, Task

logger = logging.getLogger(__name__)


def permission_for(msg: TabletMessage) -> str | None:
    """The permission kind ``msg`` needs, or None when it is always accepted."""
    if isinstance(msg, Speed):
        return "teleop"
    if isinstance(msg, Goal | Home):
        return "goals"
    if isinstance(msg, Tour | TourControl):
        return "tours"
    if isinstance(msg, RequestFrom | RequestAnswer):
        return "requests"
    return None


def describe_task(task: Task, names: dict[int, str] | None = None) -> str:
    """A short human description of a supervisor task for lists and the status line."""

    def room(node: int) -> str:
        return f"{names[node]} ({node})" if names and node in names else f"node {node}"

    if isinstance(task, GoTo):
        return f"go to {room(task.node)}"
    if isinstance(task, GuidedTour):
        return "guided tour"
    if isinstance(task, Delivery):
        return f"deliver '{task.request_text}' from {room(task.room)} to {room(task.deliver_to)}"
    if isinstance(task, GoHome):
        return "go home"
    if isinstance(task, GoToPose):
        p = task.pose
        return f"go to pose ({p.x:.2f}, {p.y:.2f}, {p.yaw:.2f} rad)"
    return str(task)  # pragma: no cover - Task is a closed union


class ErrorBudget:
    """Counts protocol errors from one connection and says when to close it."""

    def __init__(self, max_errors: int = 5, window_s: float = 10.0) -> None:
        if max_errors < 1 or not window_s > 0:
            raise ValueError("ErrorBudget needs max_errors >= 1 and window_s > 0")
        self.max_errors = max_errors
        self.window_s = window_s
        self._times: deque[float] = deque()

    def record(self, now: float, fatal: bool = False) -> bool:
        """Record one error at ``now`` [s]; True when the connection should be closed."""
        self._times.append(now)
        while self._times and now - self._times[0] > self.window_s:
            self._times.popleft()
        return fatal or len(self._times) > self.max_errors

    def reset(self) -> None:
        self._times.clear()
