"""The station's watch on the robots it does not follow closely (issue 14: per-robot supervision).

`StationLink` follows the *selected* robot with every state topic (scan, image, map...). A
station supervising a fleet must still see every other robot and drive its tasks: `FleetWatch`
subscribes, for each watched robot, to the light state a supervisor and the map need (pose,
planned path, battery, multiplexer, collision monitor: rings of one, newest value only) and to
its event topics (route progress and status, in arrival order, one wildcard subscriber per
robot), and holds one publisher per command topic so its routes, cancels, pauses and the
operator's stop reach it. Scan, image, map and odometry of a watched robot are not received.

Zenoh callbacks only queue raw bytes; `poll` decodes on the caller's thread (the Qt timer).
A robot is never watched and selected at once: the caller watches every present robot but the
selected one (`set_watched`).
"""

from __future__ import annotations

import logging
import threading
from collections import Counter

import zenoh

from interbot_core.topics import (
    STATE_TOPICS,
    TOPIC_SPECS,
    Topic,
    TopicError,
    decode,
    validate_robot_id,
)
from interbot_link.robot import LinkClosedError
from interbot_link.session import LinkError
from interbot_link.station import Followed, StateMessage

logger = logging.getLogger(__name__)

#: The newest-value topics a watched robot sends the station (what a supervisor and the map need).
WATCH_TOPICS = frozenset(
    {Topic.POSE, Topic.PLAN, Topic.BATTERY, Topic.MUX, Topic.SAFETY}
) & frozenset(t for t in STATE_TOPICS if TOPIC_SPECS[t].latest_only)
_EVENT_NAMES = frozenset(str(t) for t in STATE_TOPICS if not TOPIC_SPECS[t].latest_only) - {
    str(Topic.MAP)
}


class NotWatchedError(LinkError):
    """A command for a robot that is not watched."""


class FleetWatch:
    """Light subscriptions and command publishers for several robots on one session."""

    def __init__(self, session: zenoh.Session, *, queue_capacity: int = 4096) -> None:
        self._session = session
        self._lock = threading.Lock()
        self._raw: list[tuple[str, str, bytes]] = []
        self._capacity = queue_capacity
        self._watched: dict[str, Followed] = {}
        self._closed = False
        self.decode_errors: Counter[str] = Counter()
        self.overflow = 0

    @property
    def watched(self) -> frozenset[str]:
        return frozenset(self._watched)

    def set_watched(self, robot_ids: set[str] | frozenset[str]) -> None:
        """Watch exactly ``robot_ids`` (each validated): new ones declared, others undeclared."""
        if self._closed:
            raise LinkClosedError("fleet watch is closed")
        wanted = {validate_robot_id(r) for r in robot_ids}
        for robot_id in set(self._watched) - wanted:
            self._watched.pop(robot_id).undeclare()
        for robot_id in sorted(wanted - set(self._watched)):
            self._watched[robot_id] = self._declare(robot_id)

    def _declare(self, robot_id: str) -> Followed:
        def on_event(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr).rsplit("/", 1)[-1]
            if name in _EVENT_NAMES and sample.kind == zenoh.SampleKind.PUT:
                with self._lock:
                    if len(self._raw) >= self._capacity:
                        self.overflow += 1
                        return
                    self._raw.append((robot_id, name, sample.payload.to_bytes()))

        logger.info("station watches robot %r", robot_id)
        return Followed.declare(self._session, robot_id, WATCH_TOPICS, on_event)

    def _decode(self, robot_id: str, name: str, payload: bytes) -> StateMessage | None:
        try:
            topic = Topic(name)
            return StateMessage(robot_id, topic, decode(topic, payload))
        except (TopicError, ValueError) as exc:
            self.decode_errors[name] += 1
            logger.warning("dropped a payload on interbot/%s/%s: %s", robot_id, name, exc)
            return None

    def poll(self) -> list[StateMessage]:
        """Event messages in arrival order, then the newest light state of each watched robot."""
        with self._lock:
            raw, self._raw = self._raw, []
        out = [m for item in raw if (m := self._decode(*item)) is not None]
        for robot_id, watched in self._watched.items():
            for topic, ring in watched.rings.items():
                sample = ring.try_recv()
                if sample is not None:
                    msg = self._decode(robot_id, str(topic), sample.payload.to_bytes())
                    if msg is not None:
                        out.append(msg)
        return out

    def send(self, robot_id: str, topic: Topic, message: object) -> bool:
        """Send a command to a watched robot; True if a robot subscriber matched it."""
        if self._closed:
            raise LinkClosedError("fleet watch is closed")
        watched = self._watched.get(robot_id)
        if watched is None:
            raise NotWatchedError(f"robot {robot_id!r} is not watched")
        return watched.send(topic, message)

    def close(self) -> None:
        """Undeclare everything; idempotent."""
        if self._closed:
            return
        self._closed = True
        for watched in self._watched.values():
            watched.undeclare()
        self._watched.clear()
