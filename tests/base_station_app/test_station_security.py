"""`interbot-base-station` security settings: refused without keys off loopback, --insecure
flags in the title, keys from the command line or the station's YAML, the pairing widget."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from base_station_app import station_security
from base_station_app.main import main
from base_station_app.qt_tablet_pairing import QtTabletPairing, qr_pixmap
from base_station_app.station_file import StationFileError, StationSettingsStore
from base_station_app.tablet_auth import TabletAuthServer
from interbot_link import KeyStore


@pytest.fixture(scope="module")
def keys(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return KeyStore.init(tmp_path_factory.mktemp("k") / "keys").dir


def _resolve(**kw):
    args = dict(keys=None, identity=None, insecure=False, insecure_tablet=False,
                connect=["tcp/127.0.0.1:7447"], tablet_host="127.0.0.1")  # fmt: skip
    return station_security.resolve(**{**args, **kw})


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--connect", "tcp/192.0.2.5:7447"], "interbot keys init"),
        (["--tablet-host", "0.0.0.0"], "plaintext tablet on 0.0.0.0"),
        (["--security", "/nonexistent/keys"], "not an Interbot key directory"),
    ],
)
def test_station_refuses_to_start_insecurely_with_instructions(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_title_shows_what_is_insecure(keys: Path) -> None:
    assert _resolve().title_suffix() == ""
    both = _resolve(insecure=True, insecure_tablet=True, tablet_host="0.0.0.0")
    assert both.title_suffix() == " - INSECURE robot link and tablet link"
    secure = _resolve(keys=keys, connect=["tls/192.0.2.5:7447"], tablet_host="0.0.0.0")
    assert secure.tablet_tls and secure.title_suffix() == ""
    assert secure.link is not None and secure.link.robots == ("interbot1",)


def test_keys_from_the_station_yaml(keys: Path, tmp_path: Path) -> None:
    yaml_path = tmp_path / "station.yaml"
    yaml_path.write_text(f"security: {{keys: {keys}, identity: station}}\n")
    section = StationSettingsStore(yaml_path).load().security
    sec = _resolve(file_settings=station_security.settings_of(section, yaml_path))
    assert sec.keys == keys and sec.link is not None
    yaml_path.write_text("security: {key: x}\n")
    with pytest.raises(
        StationFileError,
        match=r"station\.yaml: unknown key 'security\.key' \(allowed: keys, identity",
    ):
        StationSettingsStore(yaml_path).load()
    with pytest.raises(station_security.StationSecurityError, match="is a robot, not a station"):
        _resolve(keys=keys, identity="interbot1")
    observer = _resolve(keys=keys, identity="observer")
    assert observer.title_suffix() == " - OBSERVER (read-only)"


def test_pairing_widget_shows_a_code_and_revokes(qtbot, keys: Path, tmp_path: Path) -> None:
    now = [time.time()]
    auth = TabletAuthServer.from_files(
        keys / "station.crt", keys / "station.key", tmp_path / "tablets.json", lambda: now[0]
    )
    widget = QtTabletPairing(auth)
    qtbot.addWidget(widget)
    widget.pair_button.click()
    assert auth.offer is not None and auth.offer.code.replace(
        " ", ""
    ) in widget.code_label.text().replace(" ", "")
    assert not widget.qr_label.pixmap().isNull() and "--pair" in widget.uri_label.text()
    auth.authorise("pair", auth.offer.code, "lobby")
    assert widget.tablets.count() == 1 and widget.code_label.text() == ""
    widget.pair_button.click()
    now[0] += auth.registry.code_ttl + 1.0  # the code expires
    qtbot.waitUntil(lambda: widget.code_label.text() == "", timeout=10_000)
    assert widget.qr_label.pixmap().isNull()
    widget.tablets.setCurrentRow(0)
    widget.revoke_button.click()
    assert auth.registry.records[0].revoked and "REVOKED" in widget.tablets.item(0).text()
    assert qr_pixmap("x").width() > 0
