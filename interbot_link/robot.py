"""The robot daemon's end of the zenoh link (thesis Fig. 4.2: Processing Unit <-> Base Station).

`RobotLink` publishes the robot's state on ``interbot/<robot_id>/<topic>``, receives the
station's commands and hands them to the daemon loop through `RobotLink.poll_commands` (zenoh
callbacks only append raw payloads to a bounded queue; decoding, validation and all daemon
logic run on the caller's thread), declares the liveliness token ``interbot/<robot_id>/alive``
while it is open, and answers the query ``interbot/<robot_id>/state`` with a snapshot of the
latest state (the map, pose, route progress ...), so a station that joins late gets the map.

The thread zenoh calls `RobotLink._on_sample` on (zenoh-python's own Python thread for this
subscriber) is raised to real-time priority on its first sample, where the OS allows it
(`interbot_link.command_priority`): a stop or a speed command is queued the moment it arrives,
even while the robot's loop and other programs keep both cores busy.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import zenoh

from interbot_core.laser_scan import LaserScan
from interbot_core.topics import (
    COMMAND_TOPICS,
    STATE_TOPICS,
    AssistMsg,
    ConfigMsg,
    GoalMsg,
    InitialPose,
    Lock,
    RangeEncoding,
    Relocalise,
    RouteCancel,
    RouteMsg,
    StopRelease,
    Topic,
    TopicError,
    Twist,
    alive_key,
    decode,
    encode,
    encode_scan,
    encode_snapshot,
    key,
    parse_key,
    robot_wildcard,
    state_key,
    to_topic,
)
from interbot_link.command_priority import PriorityOutcome, ThreadRaiser
from interbot_link.qos import declare_publisher
from interbot_link.session import LinkError

logger = logging.getLogger(__name__)

CommandMessage = (
    Twist
    | Lock
    | StopRelease
    | RouteMsg
    | RouteCancel
    | GoalMsg
    | InitialPose
    | ConfigMsg
    | AssistMsg
    | Relocalise
)

PRIORITY_TOPICS = frozenset({str(Topic.STOP), str(Topic.STOP_RELEASE)})
"""Commands on the priority lane: never queued behind other commands, never dropped for space."""
MOTION_TOPICS = frozenset({str(Topic.STATION_VEL), str(Topic.TABLET_VEL), str(Topic.PAUSE_NAV)})
"""Commands on the motion lane (with the priority lane): what a daemon's command thread applies
to the multiplexer at once, without waiting for the localiser or the planner (issue 14)."""
PRIORITY_CAPACITY = 65_536
"""Bound of the priority lane (only a broken station could fill it; then the oldest go)."""

SNAPSHOT_TOPICS = frozenset(STATE_TOPICS - {Topic.SCAN, Topic.IMAGE})
"""State kept for the ``state`` query: everything but the streams (scan, image)."""


class LinkClosedError(LinkError):
    """A link was used after `close()`."""


@dataclass(frozen=True)
class Command:
    """A decoded command from the station: its topic and message."""

    topic: Topic
    message: CommandMessage


class RobotLink:
    """Robot side of the link on an open session (the caller owns and closes the session).

    ``notify`` (optional) is called on a zenoh thread after each received command: keep it
    trivial and thread-safe (set an Event, write to a wake-up pipe).
    """

    def __init__(
        self,
        session: zenoh.Session,
        robot_id: str,
        *,
        queue_capacity: int = 1024,
        notify: Callable[[], None] | None = None,
    ) -> None:
        self._session = session
        self.robot_id = robot_id
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self._raw: list[tuple[str, bytes]] = []
        self._priority: list[tuple[str, bytes]] = []  # stop / stop_release: always first
        self._motion: list[tuple[str, bytes]] = []  # station_vel, tablet_vel, pause_nav
        self._capacity = queue_capacity
        self._notify = notify
        self._raise_thread = ThreadRaiser("the robot link's command callback thread")
        self._snapshot: dict[Topic, bytes] = {}
        self._closed = False
        self.decode_errors: Counter[str] = Counter()
        """Dropped payloads per topic name: malformed, or not a command topic."""
        self.overflow = 0
        """Commands dropped because the queue was full (the daemon loop is not polling)."""
        self.priority_overflow = 0
        """Priority commands dropped because even the priority lane was full (never in practice)."""
        self._state_key = state_key(robot_id)
        self._publishers = {
            t: declare_publisher(session, key(robot_id, t), t) for t in STATE_TOPICS
        }
        self._subscriber = session.declare_subscriber(
            robot_wildcard(robot_id), self._on_sample, allowed_origin=zenoh.Locality.REMOTE
        )
        self._queryable = session.declare_queryable(self._state_key, self._on_query)
        self._token = session.liveliness().declare_token(alive_key(robot_id))
        logger.info("robot link %r up (session %s)", robot_id, session.zid())

    @property
    def callback_priority(self) -> PriorityOutcome | None:
        """The command callback thread's scheduling (None until the first sample)."""
        return self._raise_thread.outcome

    # ------------------------------------------------------------------ zenoh threads

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """Runs on a zenoh thread: queue the raw payload, nothing else."""
        outcome = self._raise_thread()  # once per thread: real-time priority if allowed
        if outcome is not None:
            logger.log(logging.INFO if outcome.realtime else logging.WARNING, "%s", outcome.text)
        if sample.kind != zenoh.SampleKind.PUT:
            return
        item = (str(sample.key_expr), sample.payload.to_bytes())
        name = item[0].rsplit("/", 1)[-1]
        with self._cond:
            if name in PRIORITY_TOPICS:
                if len(self._priority) >= PRIORITY_CAPACITY:
                    self.priority_overflow += 1
                    del self._priority[0]
                self._priority.append(item)
            else:
                lane = self._motion if name in MOTION_TOPICS else self._raw
                if len(lane) >= self._capacity:
                    self.overflow += 1
                    return
                lane.append(item)
            self._cond.notify_all()
        if self._notify is not None:
            self._notify()

    def _on_query(self, query: zenoh.Query) -> None:
        """Runs on a zenoh thread: reply with the stored, already encoded state."""
        with self._lock:
            parts = dict(self._snapshot)
        query.reply(self._state_key, encode_snapshot(parts))

    # ------------------------------------------------------------------ daemon thread

    def poll_commands(self, motion: bool | None = None) -> list[Command]:
        """Decode and return every command received since the last call, oldest first.

        ``stop`` and ``stop_release`` come first (the priority lane), then the others. With
        ``motion=True`` only the priority and motion lanes (`MOTION_TOPICS`: what a command
        thread applies at once); with ``motion=False`` only the rest (routes, poses, config).

        Malformed payloads and state topics published by someone else are dropped, counted in
        `decode_errors` and logged; they never reach the daemon.
        """
        with self._lock:
            raw = self._take(motion)
        commands: list[Command] = []
        for key_expr, payload in raw:
            try:
                _, name = parse_key(key_expr)
                topic = to_topic(name)
                if topic not in COMMAND_TOPICS:
                    raise TopicError(f"{topic} is not a command topic")
                message = decode(topic, payload)
            except TopicError as exc:
                name = key_expr.rsplit("/", 1)[-1]
                self.decode_errors[name] += 1
                logger.warning("dropped a payload on %s: %s", key_expr, exc)
                continue
            commands.append(Command(topic, cast(CommandMessage, message)))
        return commands

    def _take(self, motion: bool | None) -> list[tuple[str, bytes]]:
        """Empty the lanes ``motion`` selects (see `poll_commands`); the lock is held."""
        taken: list[tuple[str, bytes]] = []
        if motion is not False:
            taken, self._priority, self._motion = self._priority + self._motion, [], []
        if motion is not True:
            taken, self._raw = taken + self._raw, []
        return taken

    def _pending(self, motion: bool | None) -> bool:
        fast = bool(self._priority or self._motion)
        return fast if motion else bool(self._raw) if motion is False else fast or bool(self._raw)

    def wait_commands(self, timeout: float, motion: bool | None = None) -> bool:
        """Block up to ``timeout`` [s] until a command is queued (for loops that can sleep);
        ``motion`` picks the lanes as in `poll_commands`."""
        with self._cond:
            return self._cond.wait_for(lambda: self._pending(motion), timeout)

    def subscribed(self, topic: Topic) -> bool:
        """True if some station subscribes to state ``topic`` (skip encoding images if not)."""
        status = self._publishers[topic].matching_status  # MatchingStatus in 1.10
        return bool(getattr(status, "matching", status))

    def publish(self, topic: Topic, message: object) -> None:
        """Encode ``message`` for state ``topic`` and publish it (and keep it for the query)."""
        self._put(topic, encode(topic, message))

    def _put(self, topic: Topic, payload: bytes) -> None:
        if self._closed:
            raise LinkClosedError(f"robot link {self.robot_id!r} is closed")
        if topic in SNAPSHOT_TOPICS:
            with self._lock:
                self._snapshot[topic] = payload
        self._publishers[topic].put(payload)

    def publish_scan(
        self, scan: LaserScan, encoding: RangeEncoding = RangeEncoding.FLOAT32
    ) -> None:
        self._put(Topic.SCAN, encode_scan(scan, encoding))

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Undeclare everything (the token last but one: stations see the robot leave)."""
        if self._closed:
            return
        self._closed = True
        self._subscriber.undeclare()
        self._queryable.undeclare()
        self._token.undeclare()
        for publisher in self._publishers.values():
            publisher.undeclare()
        logger.info("robot link %r closed", self.robot_id)
