"""The robots a station supervises, and which one the operator commands (issue 14).

Every robot whose liveliness token was seen gets a `RobotMirror` (its own supervisor, route
mirror and state) and keeps it while the station runs, online or not. Exactly one robot at a
time is *selected*: the operator's keys, the teleop panel, the task panel and the tablet act on
it; the others keep driving their own queues and are drawn on the map.

Which robot a (re)started station commands is decided in one place, `choose`:

* a preferred robot (``--robot ID``, else the operator's saved choice) is selected when it
  appears, and waited for until then (other robots are watched meanwhile; the station says it
  waits, naming the robots present, so the operator can choose another);
* with no preference, ``grace_s`` after the first robot was seen (robots already running are
  all discovered within milliseconds; robots started together appear over a second or two):
  one robot present is selected; several make the station **ask** the operator (never "the
  first seen"), once per set of robots, until one is chosen.

Before any robot is selected, a placeholder mirror (``robot_id`` None) takes the operator's
orders; the first robot selected adopts it, so nothing queued before is lost. Plain Python.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from base_station_app.robot_mirror import RobotMirror, RobotView


@dataclass(frozen=True)
class Select:
    """Select this robot now."""

    robot_id: str


@dataclass(frozen=True)
class Ask:
    """Several robots and no choice: ask the operator which to command."""

    robot_ids: tuple[str, ...]

    @property
    def text(self) -> str:
        return f"{len(self.robot_ids)} robots: choose the one to command"


@dataclass(frozen=True)
class Waiting:
    """The preferred robot is absent while others are online: say so (once per set)."""

    preferred: str
    robot_ids: tuple[str, ...]

    @property
    def text(self) -> str:
        return (
            f"waiting for robot {self.preferred} (--robot or the saved choice); online: "
            f"{', '.join(self.robot_ids)} - choose one in the robot list to command it"
        )


Choice = Select | Ask | Waiting | None


class Fleet:
    """Mirrors by robot id, the selected one, and the start-up choice (module docstring)."""

    def __init__(
        self,
        make_mirror: Callable[[str | None], RobotMirror],
        preferred: str | None = None,
        grace_s: float = 2.0,
    ) -> None:
        self._make = make_mirror
        self.preferred = preferred
        self.grace_s = grace_s  # [s] discovery time before one of several robots is asked for
        self.mirrors: dict[str, RobotMirror] = {}
        self._unselected = make_mirror(None)
        self.selected_id: str | None = None
        self._first_seen_at: float | None = None  # [s] when the first robot was online
        self._asked: tuple[str, ...] | None = None

    @property
    def selected(self) -> RobotMirror:
        """The commanded robot's mirror (the placeholder while none is selected)."""
        if self.selected_id is None:
            return self._unselected
        return self.mirrors[self.selected_id]

    def about(self, mirror: RobotMirror, text: str) -> str:
        """A log line about ``mirror``'s robot: another robot than the selected one is named."""
        return text if mirror is self.selected else f"[{mirror.robot_id or 'no robot'}] {text}"

    def mirror(self, robot_id: str) -> RobotMirror:
        """The mirror of ``robot_id``, created on first use."""
        mirror = self.mirrors.get(robot_id)
        if mirror is None:
            mirror = self.mirrors[robot_id] = self._make(robot_id)
        return mirror

    def all(self) -> list[RobotMirror]:
        """Every mirror that may hold orders: the robots, and the placeholder if used."""
        return ([self._unselected] if self.selected_id is None else []) + [
            self.mirrors[r] for r in sorted(self.mirrors)
        ]

    def views(self, names: dict[int, str]) -> list[RobotView]:
        """Every robot seen, by id, as the map and the robot list draw it."""
        return [self.mirrors[r].view(r == self.selected_id, names) for r in sorted(self.mirrors)]

    @property
    def online(self) -> list[str]:
        return sorted(r for r, m in self.mirrors.items() if m.online)

    def select(self, robot_id: str | None) -> tuple[RobotMirror, RobotMirror]:
        """Make ``robot_id`` the commanded robot; returns (old, new) mirrors.

        The first robot selected adopts the placeholder's supervisor when its own is idle, so
        tasks queued (and a queue held by a stop) before any robot appeared are kept.
        """
        old = self.selected
        if robot_id is None:
            self.selected_id = None
            self._unselected = self._make(None)
            return old, self._unselected
        new = self.mirror(robot_id)
        idle = not new.supervisor.queue and new.supervisor.current_task is None
        if old is self._unselected and idle:
            new.supervisor = old.supervisor
        new.commanded = True
        self.selected_id = robot_id
        self._asked = None
        return old, new

    def choose(self, now: float) -> Choice:
        """The start-up choice at ``now`` [s]: select, ask (once per set of robots), or wait."""
        if self.selected_id is not None:
            return None
        online = tuple(self.online)
        if self.preferred is not None and self.preferred in online:
            return Select(self.preferred)
        if not online:
            return None
        if self._first_seen_at is None:
            self._first_seen_at = now
        if now - self._first_seen_at < self.grace_s:
            return None
        if self.preferred is not None:
            if self._asked == online:
                return None
            self._asked = online
            return Waiting(self.preferred, online)
        if len(online) == 1:
            return Select(online[0])
        if self._asked == online:
            return None
        self._asked = online
        return Ask(online)
