"""zenoh QoS for each topic, from the pure description in `interbot_core.topics.TOPIC_SPECS`.

Must-arrive topics (stop, pause, route, goal, initial pose, config, stop release, route
progress, status) use congestion control BLOCK: a full transmit queue makes the sender wait
instead of dropping the message. So do the velocity commands (station_vel, tablet_vel; issue
14): zenoh's DROP discards the message being sent, the newest, once the queue (two batches per
priority, and every express message is a batch) has stayed full for 1 ms; a burst of key
commands while the transmit thread waited for a busy CPU lost about one in ten under load
(20 bursts of 50, load 17), and the last one lost can be the release's zero. Waiting a few
milliseconds for the queue is better than a robot that keeps the old speed until the
multiplexer's timeout. All commands share one priority so that zenoh keeps their
order on the link (stop, then stop release, arrive in that order). Streams use DROP: a late
scan is worth less than the next one.
"""

from __future__ import annotations

from dataclasses import dataclass

import zenoh

from interbot_core.topics import TOPIC_SPECS, Topic


@dataclass(frozen=True)
class Qos:
    """Publisher settings of one topic."""

    congestion_control: zenoh.CongestionControl
    priority: zenoh.Priority
    express: bool


def qos_for(topic: Topic) -> Qos:
    """The publisher QoS of ``topic``."""
    spec = TOPIC_SPECS[topic]
    block = spec.must_arrive or spec.command  # every command, the velocity streams too
    congestion = zenoh.CongestionControl.BLOCK if block else zenoh.CongestionControl.DROP
    if spec.command:
        return Qos(congestion, zenoh.Priority.INTERACTIVE_HIGH, express=True)
    if topic in (Topic.MAP, Topic.IMAGE):
        return Qos(congestion, zenoh.Priority.DATA_LOW, express=False)
    if spec.must_arrive:
        return Qos(congestion, zenoh.Priority.INTERACTIVE_LOW, express=False)
    return Qos(congestion, zenoh.Priority.DATA_HIGH, express=topic in (Topic.POSE, Topic.CMD_VEL))


def declare_publisher(session: zenoh.Session, key_expr: str, topic: Topic) -> zenoh.Publisher:
    """A publisher on ``key_expr`` with the QoS of ``topic``, delivering to other sessions only.

    Remote-only matters: each link also holds a wildcard subscriber on its robot's keys, and a
    local match would make ``matching_status`` (is anyone listening?) always true.
    """
    qos = qos_for(topic)
    return session.declare_publisher(
        key_expr,
        congestion_control=qos.congestion_control,
        priority=qos.priority,
        express=qos.express,
        allowed_destination=zenoh.Locality.REMOTE,
    )
