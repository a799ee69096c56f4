"""Keys for `interbot demo` (issue 15): the demo runs secure, with keys made on first use.

The keys live per user, outside the repository (``$INTERBOT_DEMO_KEYS``, else
``~/.config/interbot/demo-keys``), so they are never committed. The demo's tablet is paired
by the launcher itself, as an operator would at the Tablet tab: a one-time code is issued and
redeemed at once in the station's registry (``tablets-station.json``), and the token goes to
the tablet's credentials file with this run's port. Later runs reuse the same token.
"""

from __future__ import annotations

import json
import logging
import os
import secrets
from pathlib import Path

from cryptography import x509

from interbot_core.tablet_pairing import PairingError, TabletRegistry
from interbot_link.keys import INVENTORY, KeyStore, cert_sha256

logger = logging.getLogger(__name__)

STATION = "station"
TABLET_NAME = "demo tablet"


def demo_keys_dir() -> Path:
    return Path(os.environ.get("INTERBOT_DEMO_KEYS", "~/.config/interbot/demo-keys")).expanduser()


def ensure_keys(directory: Path, robot_id: str) -> KeyStore:
    """The demo's key directory, created (CA, robot, station, observer) if it does not exist."""
    if not (directory / INVENTORY).exists():
        print(f"interbot demo: creating keys in {directory} (first run)", flush=True)
        return KeyStore.init(
            directory, ((robot_id, "robot"), (STATION, "station"), ("observer", "observer"))
        )
    store = KeyStore(directory)
    if robot_id not in store.members:
        store.add(robot_id, "robot")
    return store


def _write_private(path: Path, data: object) -> None:
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
    tmp.replace(path)


def pair_demo_tablet(store: KeyStore, port: int) -> Path:
    """Register the demo tablet with the station (once) and write its credentials for ``port``."""
    registry_path = store.dir / f"tablets-{STATION}.json"
    creds_path = store.dir / "demo-tablet.json"
    registry = TabletRegistry(secrets.token_bytes)
    if registry_path.exists():
        registry = TabletRegistry.from_json(
            json.loads(registry_path.read_text(encoding="utf-8")), secrets.token_bytes
        )
    token, tablet_id = None, None
    if creds_path.exists():
        saved = json.loads(creds_path.read_text(encoding="utf-8"))
        try:
            tablet_id = registry.authenticate(str(saved.get("token"))).tablet_id
            token = str(saved["token"])
        except PairingError:
            token = None
    if token is None:
        code, _ = registry.new_code(0.0)
        record, token = registry.pair(code, TABLET_NAME, 0.0)
        tablet_id = record.tablet_id
        _write_private(registry_path, registry.to_json())
    cert = x509.load_pem_x509_certificate((store.dir / f"{STATION}.crt").read_bytes())
    creds = {
        "host": "127.0.0.1",
        "port": port,
        "fingerprint": cert_sha256(cert),
        "token": token,
        "tablet_id": tablet_id,
    }
    _write_private(creds_path, creds)
    return creds_path
