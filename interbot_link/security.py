"""Mutual TLS and access control for the zenoh link (issue 15; docs/security.md).

With a key directory (`interbot_link.keys`), every zenoh link is ``tls/`` with mutual TLS: each
side presents a certificate issued by the Interbot CA and checks the other's. On top of that,
zenoh's access control (top-level ``access_control``, default **deny**) names subjects by the
certificate's common name and allows, per key expression and message kind, only:

* on a robot ``R``: ``put`` of commands on ``interbot/R/<command>`` from stations; subscribing
  to and querying ``interbot/R/...`` state from stations and observers; and, going out, R's own
  state (``put``, ``reply``, ``declare_queryable``, ``liveliness_token``) under ``interbot/R/``
  only (so a robot cannot speak for another), plus the declaration of its command subscriber
  to stations (FIELD_NOTES: with default deny, egress ``declare_subscriber`` must be allowed or
  the station's publishers never learn that anybody listens);
* on a station (or an observer's own session): state, replies, the state queryable, liveliness
  tokens and command subscriber declarations from robot ``R`` only under ``interbot/R/``;
  commands going out (stations only), subscriptions and queries going out.

Anything else (no certificate, a certificate from another CA, a revoked or unknown name, an
observer publishing a command) is dropped by zenoh before it reaches Interbot code.

Without keys, `check_local_endpoints` refuses every endpoint that is not on the loopback
interface unless the operator says ``--insecure``.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from interbot_core.topics import (
    ALIVE,
    COMMAND_TOPICS,
    KEY_PREFIX,
    STATE_QUERY,
    STATE_TOPICS,
)
from interbot_link.errors import InsecureEndpointError
from interbot_link.keys import SETUP_HINT, Identity, KeysError, KeyStore

logger = logging.getLogger(__name__)

SECURE_SCHEME: Final = "tls"
PLAIN_SCHEME: Final = "tcp"
_COMMANDS: Final = tuple(sorted(str(t) for t in COMMAND_TOPICS))
_STATES: Final = tuple(sorted(str(t) for t in STATE_TOPICS))


@dataclass(frozen=True)
class LinkSecurity:
    """This node's identity and the names the access-control rules allow."""

    identity: Identity
    robots: tuple[str, ...]
    stations: tuple[str, ...]
    observers: tuple[str, ...]
    routers: tuple[str, ...] = ()

    @classmethod
    def load(
        cls,
        directory: str | Path,
        name: str,
        role: str,
        *,
        now: dt.datetime | None = None,
    ) -> LinkSecurity:
        """Validate ``name``'s certificate (role, CA, expiry, key) in ``directory``."""
        store = KeyStore(directory)
        identity = store.identity(name, role, now=now)
        names = {r: store.names(r, now=now) for r in ("robot", "station", "observer", "router")}
        return cls(identity, names["robot"], names["station"], names["observer"], names["router"])

    @property
    def role(self) -> str:
        return self.identity.role

    def tls(self) -> dict[str, Any]:
        """``transport/link/tls``: mutual TLS with this node's certificate both ways.

        The peer's certificate must chain to the Interbot CA; its host name is not checked
        (robots move between addresses): who it is, is its CN, which access control checks.
        """
        i = self.identity
        return {
            "root_ca_certificate": str(i.ca_cert),
            "listen_certificate": str(i.cert),
            "listen_private_key": str(i.key),
            "connect_certificate": str(i.cert),
            "connect_private_key": str(i.key),
            "enable_mtls": True,
            "verify_name_on_connect": False,
        }

    def access_control(self) -> dict[str, Any]:
        """The ``access_control`` section for this node's role (default deny)."""
        if self.role == "robot":
            rules, subjects, policies = robot_rules(
                self.identity.name, self.stations, self.observers, self.routers
            )
        elif self.role == "router":
            rules, subjects, policies = router_rules(self.robots, self.stations, self.observers)
        else:
            rules, subjects, policies = peer_rules(
                self.robots, commands=self.role == "station", routers=self.routers
            )
        return {
            "enabled": True,
            "default_permission": "deny",
            "rules": rules,
            "subjects": subjects,
            "policies": policies,
        }


def _rule(rule_id: str, flow: str, messages: list[str], keys: list[str]) -> dict[str, Any]:
    return {
        "id": rule_id,
        "messages": messages,
        "flows": [flow],
        "permission": "allow",
        "key_exprs": keys,
    }


def _alive_watch(rule_id: str, flow: str) -> dict[str, Any]:
    """Watching every robot's liveliness token (subscriber and query)."""
    messages = ["declare_liveliness_subscriber", "liveliness_query"]
    return _rule(rule_id, flow, messages, [f"{KEY_PREFIX}/*/{ALIVE}"])


def _robot_speaks(ids: list[str], base: str) -> list[dict[str, Any]]:
    """What the robot under ``base`` may send its peers: its state, the replies to its state
    query, its liveliness token and its command subscriber (three rules named ``ids``)."""
    return [
        _rule(ids[0], "ingress", ["put"], [f"{base}/{s}" for s in _STATES]),
        _rule(ids[1], "ingress", ["reply", "declare_queryable"], [f"{base}/{STATE_QUERY}"]),
        _rule(
            ids[2],
            "ingress",
            ["liveliness_token", "declare_subscriber"],
            [f"{base}/{ALIVE}", f"{base}/*"],
        ),
    ]


def _subject(subject_id: str, names: tuple[str, ...]) -> dict[str, Any]:
    # zenoh refuses an empty list; a name no certificate can carry keeps the subject inert.
    return {"id": subject_id, "cert_common_names": list(names) or ["-none-"]}


def robot_rules(
    robot_id: str,
    stations: tuple[str, ...],
    observers: tuple[str, ...],
    routers: tuple[str, ...] = (),
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """Rules, subjects and policies of robot ``robot_id``'s access control.

    A router (``interbot router --security``) relays stations' commands and enforces who sent
    them (`router_rules`), so a robot that is its client grants it what it grants stations.
    """
    base = f"{KEY_PREFIX}/{robot_id}"
    rules = [
        _rule("commands_in", "ingress", ["put"], [f"{base}/{c}" for c in _COMMANDS]),
        _rule("command_subscriber_out", "egress", ["declare_subscriber"], [f"{base}/*"]),
        _rule(
            "state_out",
            "egress",
            ["put"],
            [f"{base}/{s}" for s in _STATES],
        ),
        _rule(
            "state_query_out",
            "egress",
            ["declare_queryable", "reply"],
            [f"{base}/{STATE_QUERY}"],
        ),
        _rule("alive_out", "egress", ["liveliness_token"], [f"{base}/{ALIVE}"]),
        _rule("watch_in", "ingress", ["declare_subscriber"], [f"{base}/**"]),
        _rule("query_in", "ingress", ["query"], [f"{base}/{STATE_QUERY}"]),
        _alive_watch("alive_watch_in", "ingress"),
    ]
    watch = ["state_out", "state_query_out", "alive_out", "watch_in", "query_in", "alive_watch_in"]
    subjects = [_subject("stations", stations + routers), _subject("observers", observers)]
    policies = [
        {"rules": ["commands_in", "command_subscriber_out", *watch], "subjects": ["stations"]},
        {"rules": watch, "subjects": ["observers"]},
    ]
    return rules, subjects, policies


def peer_rules(
    robots: tuple[str, ...], *, commands: bool, routers: tuple[str, ...] = ()
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """Rules of a station (``commands=True``) or an observer facing ``robots``.

    Through a router (which checks that each robot speaks only under its own prefix,
    `router_rules`) the station accepts robot state for any robot id from the router.
    """
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    sources: list[tuple[str, str, tuple[str, ...]]] = [
        (robot, f"robot{index}", (robot,)) for index, robot in enumerate(robots)
    ]
    if routers:
        sources.append(("*", "routers", routers))
    for index, (robot, subject, names) in enumerate(sources):
        rule_ids = [f"r{index}_state_in", f"r{index}_query_in", f"r{index}_subs_in"]
        rules += _robot_speaks(rule_ids, f"{KEY_PREFIX}/{robot}")
        subjects.append(_subject(subject, names))
        policies.append({"rules": rule_ids, "subjects": [subject]})
    out = [
        _rule("watch_out", "egress", ["declare_subscriber"], [f"{KEY_PREFIX}/**"]),
        _rule("query_out", "egress", ["query"], [f"{KEY_PREFIX}/*/{STATE_QUERY}"]),
        _alive_watch("alive_watch_out", "egress"),
    ]
    if commands:
        out.append(
            _rule("commands_out", "egress", ["put"], [f"{KEY_PREFIX}/*/{c}" for c in _COMMANDS])
        )
    rules += out
    subjects.append(_subject("robots", robots + routers))
    policies.append({"rules": [r["id"] for r in out], "subjects": ["robots"]})
    return rules, subjects, policies


def router_rules(
    robots: tuple[str, ...], stations: tuple[str, ...], observers: tuple[str, ...]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """Rules of a building's router: the robot and station rules, enforced in the middle.

    Robot ``R`` may publish state, answer the state query, hold its liveliness token and
    declare its command subscriber only under ``interbot/R/``, and receives only commands for
    ``R``; stations may send commands and watch; observers only watch.
    """
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    alive = f"{KEY_PREFIX}/*/{ALIVE}"
    for index, robot in enumerate(robots):
        base = f"{KEY_PREFIX}/{robot}"
        ids = [f"r{index}_{n}" for n in ("state", "query", "subs", "cmd", "watch", "ask", "alive")]
        rules += [
            *_robot_speaks(ids, base),
            _rule(ids[3], "egress", ["put"], [f"{base}/{c}" for c in _COMMANDS]),
            _rule(ids[4], "egress", ["declare_subscriber"], [f"{base}/**"]),
            _rule(ids[5], "egress", ["query"], [f"{base}/{STATE_QUERY}"]),
            _alive_watch(ids[6], "egress"),
        ]
        subjects.append(_subject(f"robot{index}", (robot,)))
        policies.append({"rules": ids, "subjects": [f"robot{index}"]})
    any_robot = f"{KEY_PREFIX}/*"
    watch = [
        _rule("watch_in", "ingress", ["declare_subscriber"], [f"{KEY_PREFIX}/**"]),
        _rule("query_in", "ingress", ["query"], [f"{any_robot}/{STATE_QUERY}"]),
        _alive_watch("alive_watch_in", "ingress"),
        _rule("state_out", "egress", ["put"], [f"{any_robot}/{s}" for s in _STATES]),
        _rule(
            "state_query_out",
            "egress",
            ["reply", "declare_queryable"],
            [f"{any_robot}/{STATE_QUERY}"],
        ),
        _rule("alive_out", "egress", ["liveliness_token"], [alive]),
    ]
    command = [
        _rule("commands_in", "ingress", ["put"], [f"{any_robot}/{c}" for c in _COMMANDS]),
        _rule("command_subscriber_out", "egress", ["declare_subscriber"], [f"{any_robot}/*"]),
    ]
    rules += watch + command
    subjects += [_subject("stations", stations), _subject("observers", observers)]
    watch_ids = [r["id"] for r in watch]
    policies += [
        {"rules": watch_ids + [r["id"] for r in command], "subjects": ["stations"]},
        {"rules": watch_ids, "subjects": ["observers"]},
    ]
    return rules, subjects, policies


# --------------------------------------------------------------------------- endpoints


def endpoint_host(endpoint: str) -> str:
    """The host part of ``scheme/HOST:PORT`` (brackets of IPv6 removed)."""
    rest = endpoint.split("/", 1)[-1]
    return rest.rsplit(":", 1)[0].strip("[]")


def is_loopback_host(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and ``localhost``; a listen on 0.0.0.0 / :: is not."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # another host name: it may resolve anywhere


def check_local_endpoints(endpoints: list[str] | tuple[str, ...], program: str) -> None:
    """Refuse plaintext endpoints off the loopback interface (no keys, no ``--insecure``)."""
    remote = [e for e in endpoints if not is_loopback_host(endpoint_host(e))]
    if remote:
        raise InsecureEndpointError(
            f"{program}: refusing to listen on or connect to {', '.join(remote)} without "
            f"security: anyone on that network could drive the robot. To fix: {SETUP_HINT}. "
            "Or keep to 127.0.0.1, or (on a closed, trusted network only) add --insecure."
        )


def warn_insecure(program: str, endpoints: list[str] | tuple[str, ...]) -> None:
    """Log the ``--insecure`` override loudly (start-up)."""
    logger.warning(
        "%s: INSECURE: plaintext zenoh on %s; anyone who reaches these endpoints can "
        "command the robot (--insecure given; see docs/security.md)",
        program,
        ", ".join(endpoints),
    )


__all__ = [
    "InsecureEndpointError",
    "KeysError",
    "LinkSecurity",
    "check_local_endpoints",
    "is_loopback_host",
    "peer_rules",
    "robot_rules",
    "warn_insecure",
]
