"""The Base Station's security settings (issue 15; docs/security.md), from the command line or
the station's configuration file.

    interbot-base-station --security DIR [--identity station] --connect tls/ROBOT:7447
    interbot-base-station --config station.yaml     # security: {keys: DIR, identity: station}

With keys: the zenoh link is mutual TLS as ``identity`` (a station certificate in DIR), and the
tablet link is TLS with pairing (`tablet_auth.TabletAuthServer`; paired tablets are kept in
``DIR/tablets-<identity>.json``) unless ``insecure_tablet``. Without keys: robot endpoints and
the tablet address must be on the loopback interface unless ``insecure`` (robots) or
``insecure_tablet`` (the thesis's plaintext tablet) is given; both are logged as warnings and
shown in the window title.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from base_station_app.station_file import SecuritySection
from interbot_link import KeysError, KeyStore, LinkSecurity
from interbot_link.keys import SETUP_HINT
from interbot_link.security import is_loopback_host, warn_insecure

logger = logging.getLogger(__name__)


class StationSecurityError(ValueError):
    """Security settings that cannot be used; the message says how to fix them."""


@dataclass(frozen=True)
class StationSecurity:
    keys: Path | None = None
    identity: str = "station"
    insecure: bool = False
    insecure_tablet: bool = False
    link: LinkSecurity | None = None

    @property
    def tablet_tls(self) -> bool:
        return self.link is not None and not self.insecure_tablet

    def title_suffix(self) -> str:
        """What the window title adds: nothing when everything is protected."""
        if self.link is not None and self.link.role == "observer":
            return " - OBSERVER (read-only)"
        flags = []
        if self.link is None and self.insecure:
            flags.append("robot link")
        if not self.tablet_tls and self.insecure_tablet:
            flags.append("tablet link")
        return f" - INSECURE {' and '.join(flags)}" if flags else ""

    def registry_path(self) -> Path:
        assert self.keys is not None
        return self.keys / f"tablets-{self.identity}.json"


def settings_of(section: SecuritySection, path: Path) -> dict[str, Any]:
    """``section`` as a mapping, ``keys`` resolved against the file's folder."""
    settings: dict[str, Any] = msgspec.structs.asdict(section)
    if section.keys is not None:
        settings["keys"] = (path.parent / section.keys).resolve()
    return settings


def resolve(
    *,
    keys: Path | None,
    identity: str | None,
    insecure: bool,
    insecure_tablet: bool,
    connect: list[str],
    tablet_host: str,
    file_settings: dict[str, Any] | None = None,
) -> StationSecurity:
    """Merge the command line over the file, load and check the keys, check the addresses."""
    f = file_settings or {}
    keys = keys or f.get("keys")
    sec = StationSecurity(
        keys=Path(keys).expanduser() if keys else None,
        identity=identity or str(f.get("identity", "station")),
        insecure=insecure or bool(f.get("insecure", False)),
        insecure_tablet=insecure_tablet or bool(f.get("insecure_tablet", False)),
    )
    if sec.keys is not None:
        try:
            member = KeyStore(sec.keys).members.get(sec.identity)
            # An observer certificate gives a read-only station: its own access control lets
            # no command out, and the robots would drop them anyway.
            role = "observer" if member is not None and member.role == "observer" else "station"
            link = LinkSecurity.load(sec.keys, sec.identity, role)
        except KeysError as exc:
            raise StationSecurityError(f"security: {exc}") from None
        sec = StationSecurity(sec.keys, sec.identity, sec.insecure, sec.insecure_tablet, link)
        logger.info("security on: mutual TLS as %r, robots %s", sec.identity, list(link.robots))
    elif sec.insecure:
        warn_insecure("interbot-base-station", connect)
    if not sec.tablet_tls:
        if not is_loopback_host(tablet_host) and not sec.insecure_tablet:
            raise StationSecurityError(
                f"refusing to serve a plaintext tablet on {tablet_host}: anyone on that network "
                f"could act as the tablet. To fix: {SETUP_HINT} (the tablet then pairs over "
                "TLS), or keep --tablet-host 127.0.0.1, or (trusted networks only) add "
                "--insecure-tablet."
            )
        if sec.insecure_tablet:
            logger.warning(
                "INSECURE: plaintext tablet link on %s (--insecure-tablet): anyone who reaches "
                "it can act as the tablet",
                tablet_host,
            )
    return sec
