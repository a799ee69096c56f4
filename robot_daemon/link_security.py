"""The daemon's side of issue 15: its zenoh identity, or the loopback-only rule.

With ``security.keys`` (``--security DIR``) the robot's certificate is the one named after its
robot id (the access-control rules let a robot publish only under ``interbot/<its id>/``), and
every endpoint is ``tls/``. Without keys, endpoints off the loopback interface are refused with
instructions unless ``insecure`` (``--insecure``), which is logged as a warning at start.
"""

from __future__ import annotations

import logging

from interbot_link import KeysError, LinkSecurity, session_config
from interbot_link.security import warn_insecure
from robot_daemon.config import ConfigError, DaemonConfig

logger = logging.getLogger(__name__)


def link_security(config: DaemonConfig) -> tuple[LinkSecurity | None, bool]:
    """(security, insecure) for `open_session`, after checking keys and endpoints.

    Raises ConfigError (bad or missing keys) or LinkConfigError (endpoints that do not fit).
    """
    settings = config.security
    z = config.zenoh
    security = None
    if settings.keys is not None:
        try:
            security = LinkSecurity.load(settings.keys, config.robot_id, "robot")
        except KeysError as exc:
            raise ConfigError(f"security: {exc}") from None
        logger.info(
            "security on: mutual TLS as %r (%s), stations %s, observers %s",
            config.robot_id,
            settings.keys,
            list(security.stations),
            list(security.observers),
        )
    endpoints = (list(z.listen), list(z.connect))
    session_config(*endpoints, lease_ms=z.lease_ms, security=security, insecure=settings.insecure)
    if security is None and settings.insecure:
        warn_insecure("interbot-daemon", [*z.listen, *z.connect])
    return security, settings.insecure
