"""`interbot demo` runs secure: keys made on first use, the tablet paired by the launcher."""

from __future__ import annotations

import json
from pathlib import Path

from interbot_cli import demo_launcher, demo_security
from interbot_core.tablet_pairing import TabletRegistry
from interbot_link import KeyStore, LinkSecurity


def test_keys_on_first_use_and_a_paired_demo_tablet(tmp_path: Path) -> None:
    directory = tmp_path / "demo-keys"
    store = demo_security.ensure_keys(directory, "interbot1")
    assert LinkSecurity.load(directory, "interbot1", "robot").stations == ("station",)
    creds_path = demo_security.pair_demo_tablet(store, 40000)
    creds = json.loads(creds_path.read_text())
    assert (creds["host"], creds["port"]) == ("127.0.0.1", 40000)
    assert creds["fingerprint"] == store.members["station"].sha256
    registry_data = json.loads((directory / "tablets-station.json").read_text())
    registry = TabletRegistry.from_json(registry_data, lambda n: b"\0" * n)
    assert registry.authenticate(creds["token"]).name == "demo tablet"
    # A second run reuses the keys and the token, with the new port.
    again = demo_security.ensure_keys(directory, "interbot1")
    assert again.members == KeyStore(directory).members == store.members
    creds2 = json.loads(demo_security.pair_demo_tablet(again, 40001).read_text())
    assert creds2["token"] == creds["token"] and creds2["port"] == 40001


def test_secure_plan_uses_tls_and_the_keys(tmp_path: Path) -> None:
    plan = demo_launcher.plan(
        1, 0, 7447, 5555, keys=tmp_path, tablet_credentials=tmp_path / "t.json"
    )
    assert "tls/127.0.0.1:7447" in plan.daemon and "tls/127.0.0.1:7447" in plan.station
    assert plan.daemon[-2:] == plan.station[-2:] == ["--security", str(tmp_path)]
    assert plan.tablet[-2:] == ["--credentials", str(tmp_path / "t.json")]
    plain = demo_launcher.plan(1, 0, 7447, 5555)
    assert "tcp/127.0.0.1:7447" in plain.daemon and "--security" not in plain.station
