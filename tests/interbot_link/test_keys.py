"""`interbot keys`: the CA, members, revocation, and clear errors for wrong certificates."""

from __future__ import annotations

import datetime as dt
import shutil
import stat
from pathlib import Path

import pytest
from cryptography import x509

from interbot_cli.main import main as cli_main
from interbot_link import KeysError, KeyStore, LinkSecurity
from interbot_link.keys import cert_sha256

NOW = dt.datetime(2026, 6, 1, 12, 0, tzinfo=dt.UTC)


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> KeyStore:
    return KeyStore.init(tmp_path_factory.mktemp("k") / "keys", now=NOW)


def test_init_creates_a_ca_and_three_members_with_private_keys(store: KeyStore) -> None:
    assert {n: m.role for n, m in store.members.items()} == {
        "interbot1": "robot", "station": "station", "observer": "observer"
    }  # fmt: skip
    for name in ("ca", "interbot1", "station", "observer"):
        assert stat.S_IMODE((store.dir / f"{name}.key").stat().st_mode) == 0o600
    cert = x509.load_pem_x509_certificate((store.dir / "station.crt").read_bytes())
    cn = cert.subject.get_attributes_for_oid(x509.NameOID.COMMON_NAME)[0].value
    assert cn == "station"
    assert cert_sha256(cert) == store.members["station"].sha256
    identity = store.identity("station", "station", now=NOW)
    assert identity.cert == store.dir / "station.crt"
    assert KeyStore(store.dir).names("robot") == ("interbot1",)  # the inventory reloads


def test_init_refuses_an_existing_directory(store: KeyStore) -> None:
    with pytest.raises(KeysError, match="already holds"):
        KeyStore.init(store.dir)
    with pytest.raises(KeysError, match="not a new or empty directory"):
        KeyStore.init(store.dir.parent)  # holds the key directory: never chmod a user's folder


@pytest.mark.parametrize(
    ("name", "role", "match"),
    [("station", "station", "already exists"), ("a b", "robot", "invalid"),
     ("ca", "robot", "invalid"), ("x", "admin", "role")],
)  # fmt: skip
def test_bad_members_are_refused(store: KeyStore, name: str, role: str, match: str) -> None:
    with pytest.raises(KeysError, match=match):
        store.add(name, role)


def test_wrong_certificates_give_a_clear_error(
    store: KeyStore, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with pytest.raises(KeysError, match=r"no certificate for 'nobody'.*add-station nobody"):
        store.identity("nobody", "station")
    with pytest.raises(KeysError, match="is a robot, not a station"):
        store.identity("interbot1", "station", now=NOW)
    with pytest.raises(KeysError, match="expired on 2028"):
        store.identity("station", now=NOW + dt.timedelta(days=1000))
    with pytest.raises(KeysError, match="not valid before"):
        store.identity("station", now=NOW - dt.timedelta(days=1))
    other = KeyStore.init(tmp_path / "other", now=NOW)
    copy = tmp_path / "copy"
    shutil.copytree(store.dir, copy)
    shutil.copy(other.dir / "station.crt", copy / "station.crt")
    with pytest.raises(KeysError, match="not issued by this Interbot CA"):
        KeyStore(copy).identity("station", now=NOW)
    shutil.copy(store.dir / "station.crt", copy / "station.crt")
    (copy / "station.key").chmod(0o644)
    with caplog.at_level("WARNING"):
        KeyStore(copy).identity("station", now=NOW)
    assert "readable by other users" in caplog.text
    shutil.copy(store.dir / "observer.key", copy / "station.key")
    with pytest.raises(KeysError, match="not the private key"):
        KeyStore(copy).identity("station", now=NOW)
    with pytest.raises(KeysError, match=r"not an Interbot key directory.*interbot keys init"):
        KeyStore(tmp_path)


def test_revoked_members_are_refused_and_left_out_of_the_rules(tmp_path: Path) -> None:
    store = KeyStore.init(tmp_path / "k")
    store.add("tablet_station", "station")
    store.revoke("tablet_station")
    with pytest.raises(KeysError, match="revoked"):
        LinkSecurity.load(store.dir, "tablet_station", "station")
    robot = LinkSecurity.load(store.dir, "interbot1", "robot")
    assert robot.stations == ("station",)


def test_cli_init_add_revoke_list(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    directory = tmp_path / "keys"
    assert cli_main(["keys", "init", str(directory), "--robot", "bot7"]) == 0
    assert (
        cli_main(["keys", "add-robot", "bot8", "--host", "10.1.2.3", "--dir", str(directory)]) == 0
    )
    assert cli_main(["keys", "add-observer", "viewer", "--dir", str(directory)]) == 0
    assert cli_main(["keys", "revoke", "bot8", "--dir", str(directory)]) == 0
    assert cli_main(["keys", "list", "--dir", str(directory)]) == 0
    assert (
        cli_main(["keys", "export", "bot7", str(tmp_path / "bot7"), "--dir", str(directory)]) == 0
    )
    exported = sorted(p.name for p in (tmp_path / "bot7").iterdir())
    assert exported == ["bot7.crt", "bot7.key", "ca.crt", "interbot-keys.yaml"]  # no ca.key
    assert LinkSecurity.load(tmp_path / "bot7", "bot7", "robot").stations == ("station",)
    out = capsys.readouterr().out
    assert "bot8" in out and "REVOKED" in out and "viewer" in out
    cert = x509.load_pem_x509_certificate((directory / "bot8.crt").read_bytes())
    sans = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert "10.1.2.3" in {str(ip) for ip in sans.get_values_for_type(x509.IPAddress)}
    assert cli_main(["keys", "revoke", "ghost", "--dir", str(directory)]) == 2
    assert "no member 'ghost'" in capsys.readouterr().err
