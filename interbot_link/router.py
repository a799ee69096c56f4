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

import logging
import threading
from collections.abc import Sequence

import zenoh

from interbot_link.security import LinkSecurity, check_local_endpoints
from interbot_link.session import (
    DEFAULT_LEASE_MS,
    LinkConfigError,
    LinkOpenError,
    build_config,
    check_lease,
    validate_endpoint,
)

logger = logging.getLogger(__name__)


def router_config(
    listen: Sequence[str],
    lease_ms: int = DEFAULT_LEASE_MS,
    *,
    security: LinkSecurity | None = None,
    insecure: bool = False,
) -> zenoh.Config:
    """A router listening exactly on ``listen`` (TCP), no scouting, ``lease_ms`` link lease.

    With ``security`` (a router certificate, issue 15) it listens on ``tls/`` with mutual TLS
    and enforces `interbot_link.security.router_rules`; without it, endpoints off the loopback
    interface are refused unless ``insecure``.
    """
    if isinstance(listen, str) or not listen:
        raise LinkConfigError("a router needs a list of at least one listen endpoint")
    endpoints = [validate_endpoint(e, listen=True, secure=security is not None) for e in listen]
    if security is None and not insecure:
        check_local_endpoints(endpoints, "interbot router")
    if security is not None and security.role != "router":
        raise LinkConfigError(f"{security.identity.name!r} is a {security.role}, not a router")
    check_lease(lease_ms)
    settings: dict[str, object] = {
        "mode": "router",
        "listen/endpoints": endpoints,
        "connect/endpoints": [],
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
    }
    return build_config(settings, lease_ms, security)


def open_router(
    listen: Sequence[str],
    lease_ms: int = DEFAULT_LEASE_MS,
    *,
    security: LinkSecurity | None = None,
    insecure: bool = False,
) -> zenoh.Session:
    """Open the router session (close it when done: zenoh-python#434)."""
    config = router_config(listen, lease_ms, security=security, insecure=insecure)
    try:
        session = zenoh.open(config)
    except zenoh.ZError as exc:
        raise LinkOpenError(f"cannot open the zenoh router on {list(listen)}: {exc}") from exc
    logger.info("zenoh router %s listening on %s", session.zid(), list(listen))
    return session


def run_router(
    listen: Sequence[str],
    stop: threading.Event,
    lease_ms: int = DEFAULT_LEASE_MS,
    *,
    security: LinkSecurity | None = None,
    insecure: bool = False,
) -> None:
    """Route until ``stop`` is set; the session is closed on every exit path."""
    session = open_router(listen, lease_ms, security=security, insecure=insecure)
    try:
        while not stop.wait(1.0):
            pass
    finally:
        session.close()
        logger.info("zenoh router stopped")
