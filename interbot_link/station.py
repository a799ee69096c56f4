"""The Base Station's end of the zenoh link.

`StationLink` watches the liveliness tokens ``interbot/*/alive`` (robots appearing and leaving,
including those already present, through a liveliness subscriber with history and a liveliness
get), follows one selected robot and sends it commands. High-rate state (scan, pose, odom,
cmd_vel, image, battery, mux) is received with ``zenoh.handlers.RingChannel(1)``: `poll_state`
returns only the newest sample of each, so a slow UI drops frames instead of falling behind.
Events (route progress, status, map, robots appearing/leaving) go, in arrival order, to a
bounded queue drained by `poll_events`. Zenoh callbacks only queue raw bytes; decoding happens on the caller's thread.

Call `poll_state` / `poll_events` from one thread (the Qt timer); ``notify`` is invoked on a
zenoh thread when an event is queued: emit a queued Qt signal from it, nothing more.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from interbot_core.topics import (
    ALIVE,
    ALIVE_WILDCARD,
    COMMAND_TOPICS,
    STATE_TOPICS,
    TOPIC_SPECS,
    Topic,
    TopicError,
    decode,
    decode_snapshot,
    encode,
    key,
    parse_key,
    robot_wildcard,
    state_key,
    validate_robot_id,
)
from interbot_link.qos import declare_publisher
from interbot_link.robot import LinkClosedError
from interbot_link.session import LinkError

logger = logging.getLogger(__name__)

LATEST_TOPICS = frozenset(t for t in STATE_TOPICS if TOPIC_SPECS[t].latest_only)
EVENT_TOPICS = frozenset(STATE_TOPICS - LATEST_TOPICS)
_EVENT_NAMES = frozenset(str(t) for t in EVENT_TOPICS)


class NoRobotSelectedError(LinkError):
    """A command was sent before `StationLink.select_robot`."""


@dataclass(frozen=True)
class RobotAppeared:
    """A robot's liveliness token appeared."""

    robot_id: str


@dataclass(frozen=True)
class RobotLeft:
    """A robot's liveliness token went (clean exit, killed process, or link lease expired)."""

    robot_id: str


@dataclass(frozen=True)
class StateMessage:
    """A decoded event-topic message (route progress, status, map) from a robot."""

    robot_id: str
    topic: Topic
    message: object


LinkEvent = RobotAppeared | RobotLeft | StateMessage


@dataclass
class Followed:
    """What a station declares for one robot it follows: rings of one for its newest state,
    one wildcard subscriber for its events (one zenoh thread, so their order is kept; the
    callback ignores other topics by name), and a publisher per command topic."""

    rings: dict[Topic, zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]]]
    events: zenoh.Subscriber[None]
    publishers: dict[Topic, zenoh.Publisher]

    @classmethod
    def declare(
        cls,
        session: zenoh.Session,
        robot_id: str,
        ring_topics: frozenset[Topic],
        on_event: Callable[[zenoh.Sample], None],
    ) -> Followed:
        return cls(
            {
                t: session.declare_subscriber(key(robot_id, t), zenoh.handlers.RingChannel(1))
                for t in ring_topics
            },
            session.declare_subscriber(
                robot_wildcard(robot_id), on_event, allowed_origin=zenoh.Locality.REMOTE
            ),
            {t: declare_publisher(session, key(robot_id, t), t) for t in COMMAND_TOPICS},
        )

    def send(self, topic: Topic, message: object) -> bool:
        """Publish a command; True if a robot subscriber matched it (False: nobody heard it)."""
        if topic not in COMMAND_TOPICS:
            raise TopicError(f"{topic} is not a command topic")
        publisher = self.publishers[topic]
        publisher.put(encode(topic, message))
        status = publisher.matching_status  # a MatchingStatus in 1.10 (the stub says bool)
        return bool(getattr(status, "matching", status))

    def undeclare(self) -> None:
        for ring in self.rings.values():
            ring.undeclare()
        self.events.undeclare()
        for pub in self.publishers.values():
            pub.undeclare()


_Raw = tuple[str, str, bytes] | RobotAppeared | RobotLeft  # (robot_id, topic, payload) or event


class StationLink:
    """Station side of the link on an open session (the caller owns and closes the session)."""

    def __init__(
        self,
        session: zenoh.Session,
        *,
        queue_capacity: int = 4096,
        notify: Callable[[], None] | None = None,
    ) -> None:
        self.session = session  # also for other links sharing it (replay control)
        self._lock = threading.Lock()
        self._raw: list[_Raw] = []
        self._capacity = queue_capacity
        self._notify = notify
        self._robots: set[str] = set()
        self._heard: set[str] = set()  # robots the liveliness subscriber has reported
        self._selected: str | None = None
        self._followed: Followed | None = None
        self._closed = False
        self.decode_errors: Counter[str] = Counter()
        """Dropped payloads per topic name."""
        self.overflow = 0
        """Events dropped because the queue was full (nobody polls)."""
        liveliness = session.liveliness()
        self._alive_sub = liveliness.declare_subscriber(
            ALIVE_WILDCARD, self._on_alive, history=True
        )
        liveliness.get(ALIVE_WILDCARD, self._on_alive_reply)

    # ------------------------------------------------------------------ zenoh threads

    def _queue(self, item: _Raw) -> None:
        with self._lock:
            if len(self._raw) >= self._capacity:
                self.overflow += 1
                return
            self._raw.append(item)
        if self._notify is not None:
            self._notify()

    def _robot_from_alive(self, key_expr: str) -> str | None:
        try:
            robot_id, name = parse_key(key_expr)
        except TopicError:
            return None
        return robot_id if name == ALIVE else None

    def _on_alive(self, sample: zenoh.Sample) -> None:
        robot_id = self._robot_from_alive(str(sample.key_expr))
        if robot_id is None:
            return
        present = sample.kind == zenoh.SampleKind.PUT
        with self._lock:
            self._heard.add(robot_id)
            changed = (robot_id in self._robots) != present
            if present:
                self._robots.add(robot_id)
            else:
                self._robots.discard(robot_id)
        if changed:
            self._queue(RobotAppeared(robot_id) if present else RobotLeft(robot_id))

    def _on_alive_reply(self, reply: zenoh.Reply) -> None:
        sample = reply.ok
        robot_id = None if sample is None else self._robot_from_alive(str(sample.key_expr))
        if robot_id is None:
            return
        with self._lock:
            # The subscriber (history=True) is authoritative once it has spoken about a robot.
            new = robot_id not in self._heard and robot_id not in self._robots
            if new:
                self._robots.add(robot_id)
        if new:
            self._queue(RobotAppeared(robot_id))

    def _on_event_sample(self, robot_id: str) -> Callable[[zenoh.Sample], None]:
        """One subscriber for all event topics, so that their order is kept (one thread)."""

        def on_sample(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr).rsplit("/", 1)[-1]
            if name in _EVENT_NAMES and sample.kind == zenoh.SampleKind.PUT:
                self._queue((robot_id, name, sample.payload.to_bytes()))

        return on_sample

    def _on_state_reply(self, robot_id: str) -> Callable[[zenoh.Reply], None]:
        def on_reply(reply: zenoh.Reply) -> None:
            sample = reply.ok
            if sample is not None:
                self._queue((robot_id, "state", sample.payload.to_bytes()))

        return on_reply

    # ------------------------------------------------------------------ robots

    @property
    def robots(self) -> frozenset[str]:
        """Robots whose liveliness token is present."""
        with self._lock:
            return frozenset(self._robots)

    @property
    def selected(self) -> str | None:
        return self._selected

    def select_robot(self, robot_id: str | None) -> None:
        """Follow ``robot_id`` (None: none): subscribe to its state, ask for its snapshot."""
        self._check_open()
        self._unselect()
        if robot_id is None:
            return
        validate_robot_id(robot_id)
        on_event = self._on_event_sample(robot_id)
        self._followed = Followed.declare(self.session, robot_id, LATEST_TOPICS, on_event)
        self._selected = robot_id
        self.request_state(robot_id)
        logger.info("station follows robot %r", robot_id)

    def _unselect(self) -> None:
        if self._followed is not None:
            self._followed.undeclare()
        self._followed, self._selected = None, None

    # ------------------------------------------------------------------ receiving

    def _decode(self, robot_id: str, name: str, payload: bytes) -> list[StateMessage]:
        try:
            if name == "state":
                parts = decode_snapshot(payload)
                return [StateMessage(robot_id, t, decode(t, data)) for t, data in parts.items()]
            topic = Topic(name)
            return [StateMessage(robot_id, topic, decode(topic, payload))]
        except TopicError as exc:
            self.decode_errors[name] += 1
            logger.warning("dropped a payload on interbot/%s/%s: %s", robot_id, name, exc)
            return []

    def poll_events(self) -> list[LinkEvent]:
        """Robots appearing/leaving and decoded event messages since the last call, in order."""
        with self._lock:
            raw, self._raw = self._raw, []
        events: list[LinkEvent] = []
        for item in raw:
            if isinstance(item, RobotAppeared | RobotLeft):
                events.append(item)
            else:
                events.extend(self._decode(*item))
        return events

    def poll_state(self) -> dict[Topic, object]:
        """The newest message of each high-rate topic that has a new one since the last call."""
        fresh: dict[Topic, object] = {}
        robot_id, followed = self._selected, self._followed
        for topic, ring in (followed.rings if followed is not None else {}).items():
            sample = ring.try_recv()
            if sample is None or robot_id is None:
                continue
            for msg in self._decode(robot_id, str(topic), sample.payload.to_bytes()):
                fresh[topic] = msg.message
        return fresh

    def request_state(self, robot_id: str | None = None) -> None:
        """Ask for the robot's state snapshot; its parts arrive as StateMessage events."""
        robot_id = self._target(robot_id)
        self.session.get(state_key(robot_id), self._on_state_reply(robot_id), timeout=5.0)

    # ------------------------------------------------------------------ sending

    def _target(self, robot_id: str | None) -> str:
        self._check_open()
        if robot_id is not None:
            return validate_robot_id(robot_id)
        if self._selected is None:
            raise NoRobotSelectedError("no robot selected: call select_robot(robot_id) first")
        return self._selected

    def send(self, topic: Topic, message: object) -> bool:
        """Send a command to the selected robot; True if a robot subscriber matched it.

        False means nobody received it (robot gone or not yet connected): the UI should say so.
        """
        self._target(None)
        assert self._followed is not None  # a robot is selected
        return self._followed.send(topic, message)

    # ------------------------------------------------------------------ lifetime

    def _check_open(self) -> None:
        if self._closed:
            raise LinkClosedError("station link is closed")

    def close(self) -> None:
        """Undeclare every subscriber and publisher; idempotent."""
        if self._closed:
            return
        self._closed = True
        self._unselect()
        self._alive_sub.undeclare()
