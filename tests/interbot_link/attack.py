"""The attacker of the link security tests (`test_link_security`, `test_link_router_security`):
a zenoh session that publishes on every command topic of a robot."""

from __future__ import annotations

import time

import zenoh

from interbot_core.topics import COMMAND_TOPICS, key
from interbot_link import RobotLink

# A valid ``Twist``: it decodes on the velocity topics and is counted as a decode error on the
# others, so anything that reached the robot shows up by name.
PAYLOAD = b'{"linear": 1.0, "angular": 0.0, "stamp": 0.0}'


def attack(
    session: zenoh.Session, robot: RobotLink, robot_id: str, until: frozenset[str] = frozenset()
) -> set[str]:
    """Publish on every command topic of ``robot_id`` (stop_release included); return the
    topics that arrived at ``robot``.

    At least three rounds; for the control (``until``: the topics a station may send) more
    rounds, up to 10 s, until they have all arrived: a loaded machine may not have settled
    the link or routed the declarations yet after the fixed 0.3 s pause (a put nobody is
    known to want goes nowhere).
    """
    arrived: set[str] = set()
    deadline = time.monotonic() + 10.0
    rounds = 0
    while rounds < 3 or (not until <= arrived and time.monotonic() < deadline):
        for topic in sorted(COMMAND_TOPICS):
            session.put(key(robot_id, topic), PAYLOAD)
        time.sleep(0.05)
        rounds += 1
        arrived |= {str(c.topic) for c in robot.poll_commands()} | set(robot.decode_errors)
    robot.wait_commands(0.3)
    arrived |= {str(c.topic) for c in robot.poll_commands()} | set(robot.decode_errors)
    robot.decode_errors.clear()
    return arrived
