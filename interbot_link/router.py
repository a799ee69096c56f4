"""A zenoh router for a building: robots and stations meet through it instead of by address.

One router per building (or floor) listens on a known address; robots and Base Stations are
zenoh *clients* of it (``mode: client`` and ``connect: [router]``), so a station sees every
robot that is connected to the router without knowing the robots' addresses, and a robot that
restarts or moves to another access point simply reconnects. The router is hardened like every
Interbot session: multicast scouting and gossip off, only the listen endpoints given, a bounded
link lease (a robot that vanishes is reported gone within ``lease_ms``).

Checked here (zenoh 1.x): *client* sessions route through a router; *peer* sessions with
gossip off do not (each peer would need to learn the others' addresses), which is why the
building layout uses clients.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Sequence

import zenoh

from interbot_link.session import (
    DEFAULT_LEASE_MS,
    KEEP_ALIVE_PER_LEASE,
    LinkConfigError,
    LinkOpenError,
    validate_endpoint,
)

logger = logging.getLogger(__name__)


def router_config(listen: Sequence[str], lease_ms: int = DEFAULT_LEASE_MS) -> zenoh.Config:
    """A router listening exactly on ``listen`` (TCP), no scouting, ``lease_ms`` link lease."""
    if isinstance(listen, str) or not listen:
        raise LinkConfigError("a router needs a list of at least one listen endpoint")
    endpoints = [validate_endpoint(e, listen=True) for e in listen]
    if isinstance(lease_ms, bool) or not isinstance(lease_ms, int) or not 500 <= lease_ms <= 60000:
        raise LinkConfigError(f"lease_ms must be an integer in 500..60000, got {lease_ms!r}")
    config = zenoh.Config()
    settings: dict[str, object] = {
        "mode": "router",
        "listen/endpoints": endpoints,
        "connect/endpoints": [],
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
        "transport/link/tx/lease": lease_ms,
        "transport/link/tx/keep_alive": KEEP_ALIVE_PER_LEASE,
        "adminspace/enabled": False,
    }
    for key_path, value in settings.items():
        config.insert_json5(key_path, json.dumps(value))
    return config


def open_router(listen: Sequence[str], lease_ms: int = DEFAULT_LEASE_MS) -> zenoh.Session:
    """Open the router session (close it when done: zenoh-python#434)."""
    try:
        session = zenoh.open(router_config(listen, lease_ms))
    except zenoh.ZError as exc:
        raise LinkOpenError(f"cannot open the zenoh router on {list(listen)}: {exc}") from exc
    logger.info("zenoh router %s listening on %s", session.zid(), list(listen))
    return session


def run_router(
    listen: Sequence[str], stop: threading.Event, lease_ms: int = DEFAULT_LEASE_MS
) -> None:
    """Route until ``stop`` is set; the session is closed on every exit path."""
    session = open_router(listen, lease_ms)
    try:
        while not stop.wait(1.0):
            pass
    finally:
        session.close()
        logger.info("zenoh router stopped")
