"""`interbot-tablet` picks its link: paired TLS, or plaintext only to this machine."""

from __future__ import annotations

from pathlib import Path

import pytest

from interbot_core.tablet_pairing import PairingError, PairingOffer
from tablet_app.main import make_connection, parse_args
from tablet_app.pairing import PairedTlsConnection, TabletCredentials

FP = "cd" * 32


def _connection(qtbot, argv: list[str]):
    conn = make_connection(parse_args(argv))
    conn.setParent(None)
    return conn


def test_unpaired_tablet_refuses_plaintext_off_this_machine(tmp_path: Path) -> None:
    creds = ["--credentials", str(tmp_path / "none.json")]
    with pytest.raises(PairingError, match=r"not paired.*Pair a tablet"):
        make_connection(parse_args(["--host", "192.0.2.5", *creds]))


def test_pair_uri_and_saved_credentials_give_a_pinned_tls_link(qtbot, tmp_path: Path) -> None:
    path = tmp_path / "tablet.json"
    uri = PairingOffer("192.0.2.5", 6000, FP, "123456", 0.0).uri
    conn = _connection(qtbot, ["--pair", uri, "--credentials", str(path)])
    assert isinstance(conn._link, PairedTlsConnection) and conn._link.fingerprint == FP
    assert (conn.host, conn.port) == ("192.0.2.5", 6000)
    TabletCredentials("192.0.2.5", 6000, FP, "ab" * 32, "t1").save(path)
    paired = _connection(qtbot, ["--credentials", str(path)])
    assert isinstance(paired._link, PairedTlsConnection) and paired.host == "192.0.2.5"
    other = _connection(
        qtbot, ["--host", "127.0.0.1", "--port", "7000", "--credentials", str(path)]
    )
    assert not isinstance(other._link, PairedTlsConnection)  # another station: plaintext local
    insecure = ["--host", "192.0.2.9", "--insecure-tablet", "--credentials", str(path)]
    assert not isinstance(_connection(qtbot, insecure)._link, PairedTlsConnection)
