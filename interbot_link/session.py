"""Explicit zenoh session configuration for the Interbot link (see shared/FIELD_NOTES.md, zenoh).

The default `zenoh.Config()` listens on every interface and scouts by UDP multicast
(224.0.0.224), which on an office network finds and joins any zenoh node in range. Interbot
builds every configuration explicitly instead: multicast scouting and gossip off, the listen and
connect endpoints exactly as given, and a bounded link lease, so that a frozen robot
or a pulled cable is reported ("robot lost") after ``lease_ms`` instead of the default 10 s.
Robots listen; a Base Station connects to each robot (or to a ``zenohd`` router).

Endpoints are ``tcp/`` (plaintext) or, with a `LinkSecurity` (``--security DIR``), ``tls/`` with
mutual TLS and default-deny access control (`interbot_link.security`). Plaintext endpoints off
the loopback interface are refused unless ``insecure=True`` (``--insecure``).
"""

from __future__ import annotations

import ipaddress
import json
import logging
import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Annotated

import zenoh
from msgspec import Meta

from interbot_core import schema
from interbot_link.errors import (
    InsecureEndpointError,
    LinkConfigError,
    LinkError,
    LinkOpenError,
)
from interbot_link.security import (
    PLAIN_SCHEME,
    SECURE_SCHEME,
    LinkSecurity,
    check_local_endpoints,
)

logger = logging.getLogger(__name__)

__all__ = [
    "InsecureEndpointError",
    "LinkConfigError",
    "LinkError",
    "LinkOpenError",
    "open_session",
    "session_config",
    "validate_endpoint",
]

DEFAULT_LEASE_MS = 2500
KEEP_ALIVE_PER_LEASE = 4
"""Keep-alive messages sent per lease period (zenoh's default ratio): 625 ms at 2.5 s."""
CONNECT_RETRY_INIT_MS = 200
CONNECT_RETRY_MAX_MS = 2000
MODES = ("peer", "client")

_ENDPOINT = re.compile(
    r"(?P<scheme>tcp|tls)/(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(?P<port>[0-9]{1,5})"
)


def validate_endpoint(endpoint: str, *, listen: bool, secure: bool = False) -> str:
    """Return ``endpoint`` if it is ``tcp/HOST:PORT`` (or ``tls/``) and safe, else raise.

    With ``secure`` the endpoint must be ``tls/HOST:PORT`` instead (and ``tls/`` is refused
    without it: TLS needs the keys of ``--security``).

    Multicast addresses are refused (they would scout); connecting to an unspecified address
    (0.0.0.0, ::) or to port 0 is refused; listening on port 0 is allowed (the OS picks).
    """
    match = _ENDPOINT.fullmatch(endpoint) if isinstance(endpoint, str) else None
    if match is None:
        raise LinkConfigError(
            f"endpoint {endpoint!r} is not tcp/HOST:PORT (e.g. tcp/127.0.0.1:7447) or, "
            "with --security, tls/HOST:PORT; no other protocols are allowed"
        )
    scheme = match["scheme"]
    if secure and scheme != SECURE_SCHEME:
        raise LinkConfigError(
            f"endpoint {endpoint!r}: with --security every endpoint must be "
            f"tls/HOST:PORT (e.g. tls/127.0.0.1:7447)"
        )
    if not secure and scheme != PLAIN_SCHEME:
        raise LinkConfigError(
            f"endpoint {endpoint!r} is not tcp/HOST:PORT: tls/ endpoints need keys "
            "(--security DIR; see docs/security.md)"
        )
    host, port = match["host"].strip("[]"), int(match["port"])
    if port > 65535 or (port == 0 and not listen):
        raise LinkConfigError(f"endpoint {endpoint!r}: port must be 1..65535")
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        address = None  # a host name
    if address is not None:
        if address.is_multicast:
            raise LinkConfigError(f"endpoint {endpoint!r} is a multicast address (scouting)")
        if address.is_unspecified and not listen:
            raise LinkConfigError(f"endpoint {endpoint!r}: cannot connect to {host}")
    return endpoint


def session_config(
    listen: Sequence[str],
    connect: Sequence[str],
    mode: str = "peer",
    lease_ms: int = DEFAULT_LEASE_MS,
    *,
    security: LinkSecurity | None = None,
    insecure: bool = False,
) -> zenoh.Config:
    """A zenoh.Config with exactly these endpoints, no scouting and a ``lease_ms`` link lease.

    Multicast scouting and gossip are disabled, so the session talks only to ``connect`` and
    to whoever connects to ``listen``. Connecting retries in the background (200 ms doubling
    to 2 s), so a station may start before its robot and re-joins a restarted robot.

    ``security`` turns on mutual TLS and access control (every endpoint ``tls/``); without it,
    endpoints off the loopback interface raise `InsecureEndpointError` unless ``insecure``.
    """
    if mode not in MODES:
        raise LinkConfigError(f"mode {mode!r} not supported; use one of {list(MODES)}")
    if isinstance(listen, str) or isinstance(connect, str):
        raise LinkConfigError("listen and connect must be lists of endpoints, not strings")
    secure = security is not None
    listen = [validate_endpoint(e, listen=True, secure=secure) for e in listen]
    connect = [validate_endpoint(e, listen=False, secure=secure) for e in connect]
    if not secure and not insecure:
        check_local_endpoints([*listen, *connect], "zenoh link")
    if not listen and not connect:
        raise LinkConfigError("give at least one listen or connect endpoint")
    if mode == "client" and (listen or not connect):
        raise LinkConfigError("a client only connects: give connect endpoints and no listen")
    check_lease(lease_ms)
    settings: dict[str, object] = {
        "mode": mode,
        "listen/endpoints": listen,
        "connect/endpoints": connect,
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
        "scouting/delay": 0,
        "connect/retry": {
            "period_init_ms": CONNECT_RETRY_INIT_MS,
            "period_max_ms": CONNECT_RETRY_MAX_MS,
            "period_increase_factor": 2,
        },
    }
    return build_config(settings, lease_ms, security)


def check_lease(lease_ms: int) -> None:
    schema.checked(lease_ms, Annotated[int, Meta(ge=500, le=60000)], "lease_ms", LinkConfigError)


def build_config(
    settings: dict[str, object], lease_ms: int, security: LinkSecurity | None
) -> zenoh.Config:
    """``settings`` plus what every Interbot node shares (lease, keep-alive, no admin space,
    TLS and access control when secure) as a `zenoh.Config`."""
    settings = {
        **settings,
        "transport/link/tx/lease": lease_ms,
        "transport/link/tx/keep_alive": KEEP_ALIVE_PER_LEASE,
        "adminspace/enabled": False,
    }
    if security is not None:
        settings["transport/link/tls"] = security.tls()
        settings["access_control"] = security.access_control()
    config = zenoh.Config()
    for key_path, value in settings.items():
        config.insert_json5(key_path, json.dumps(value))
    return config


@contextmanager
def open_session(
    listen: Sequence[str],
    connect: Sequence[str],
    mode: str = "peer",
    lease_ms: int = DEFAULT_LEASE_MS,
    *,
    security: LinkSecurity | None = None,
    insecure: bool = False,
) -> Iterator[zenoh.Session]:
    """Open a session from `session_config` and close it on every exit path (zenoh-python#434)."""
    config = session_config(listen, connect, mode, lease_ms, security=security, insecure=insecure)
    try:
        session = zenoh.open(config)
    except zenoh.ZError as exc:
        raise LinkOpenError(
            f"cannot open zenoh session (listen={list(listen)}, connect={list(connect)}): {exc}"
        ) from exc
    logger.info("zenoh session %s open: listen=%s connect=%s", session.zid(), listen, connect)
    try:
        yield session
    finally:
        session.close()
        logger.info("zenoh session closed")
