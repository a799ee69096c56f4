"""The zenoh ends of replay control (keys and codecs in `interbot_core.replay_control`).

`ReplayControlServer` runs in ``interbot replay``: it receives `ReplayCommand` for its robot id
and publishes `ReplayState`. `ReplayControlClient` runs in the station: it keeps the newest
`ReplayState` of every replayed robot it hears and sends commands to one. Zenoh callbacks only
queue or store raw bytes; decoding and validation run on the caller's thread.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter

import zenoh

from interbot_core.replay_control import (
    STATE_WILDCARD,
    ReplayCommand,
    ReplayState,
    control_key,
    decode_command,
    decode_state,
    encode,
    robot_of_state_key,
    state_key,
)
from interbot_core.topics import TopicError

logger = logging.getLogger(__name__)


class ReplayControlServer:
    """The replay's end: commands in, state out."""

    def __init__(self, session: zenoh.Session, robot_id: str, capacity: int = 64) -> None:
        self._lock = threading.Lock()
        self._raw: list[bytes] = []
        self._capacity = capacity
        self.decode_errors = 0
        self._publisher = session.declare_publisher(
            state_key(robot_id), congestion_control=zenoh.CongestionControl.DROP
        )
        self._subscriber = session.declare_subscriber(control_key(robot_id), self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self._lock:
            if len(self._raw) < self._capacity:
                self._raw.append(sample.payload.to_bytes())

    def poll_commands(self) -> list[ReplayCommand]:
        with self._lock:
            raw, self._raw = self._raw, []
        commands = []
        for payload in raw:
            try:
                commands.append(decode_command(payload))
            except TopicError as exc:
                self.decode_errors += 1
                logger.warning("dropped a replay command: %s", exc)
        return commands

    def publish_state(self, state: ReplayState) -> None:
        self._publisher.put(encode(state))

    def close(self) -> None:
        self._subscriber.undeclare()
        self._publisher.undeclare()


class ReplayControlClient:
    """The station's end: the newest state of every replay, and commands to one of them."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session
        self._lock = threading.Lock()
        self._latest: dict[str, bytes] = {}
        self._publishers: dict[str, zenoh.Publisher] = {}
        self.decode_errors: Counter[str] = Counter()
        self._subscriber = session.declare_subscriber(STATE_WILDCARD, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        with self._lock:
            self._latest[key] = sample.payload.to_bytes()

    def poll_states(self) -> dict[str, ReplayState]:
        """The newest state of each replayed robot heard since the last call."""
        with self._lock:
            raw, self._latest = self._latest, {}
        states = {}
        for key, payload in raw.items():
            try:
                states[robot_of_state_key(key)] = decode_state(payload)
            except (TopicError, ValueError) as exc:
                self.decode_errors[key] += 1
                logger.warning("dropped a replay state on %s: %s", key, exc)
        return states

    def send(self, robot_id: str, command: ReplayCommand) -> None:
        publisher = self._publishers.get(robot_id)
        if publisher is None:
            publisher = self._publishers[robot_id] = self._session.declare_publisher(
                control_key(robot_id), reliability=zenoh.Reliability.RELIABLE
            )
        publisher.put(encode(command))

    def close(self) -> None:
        self._subscriber.undeclare()
        for publisher in self._publishers.values():
            publisher.undeclare()
        self._publishers.clear()
