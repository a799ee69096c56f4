"""The station file owns every station setting that changes behaviour (issue 13): declared,
validated with errors that name the file, key, value and range, written back atomically, and
nothing behavioural left in QSettings."""

from __future__ import annotations

import ast
from pathlib import Path

import msgspec
import pytest
import yaml

from base_station_app.station_config import RANGES, StationConfig
from base_station_app.station_file import StationFileError, StationSettingsStore, migrate_legacy
from base_station_app.tablet_policy import EVERYTHING

REPO = Path(__file__).resolve().parents[2]


def test_missing_file_is_the_defaults_and_save_round_trips(tmp_path: Path) -> None:
    store = StationSettingsStore(tmp_path / "sub" / "station.yaml")
    assert store.load().config == StationConfig()
    config = StationConfig(latency_ceiling=0.3, goal_tolerance=0.4)
    store.save(config, msgspec.structs.replace(EVERYTHING, teleop=False))
    again = StationSettingsStore(store.path).load()
    assert again.config == config
    assert again.tablet.permissions() == msgspec.structs.replace(EVERYTHING, teleop=False)
    assert list(store.path.parent.iterdir()) == [store.path]  # no temporary file left behind


def test_save_keeps_the_security_section_as_written(tmp_path: Path) -> None:
    path = tmp_path / "station.yaml"
    path.write_text("security: {keys: ../keys, identity: desk2}\nconfig: {yaw_tolerance: 0.5}\n")
    store = StationSettingsStore(path)
    file = store.load()
    assert file.config.yaw_tolerance == 0.5 and file.security.identity == "desk2"
    store.save(file.config, msgspec.structs.replace(EVERYTHING, tours=False))
    saved = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert saved["security"]["keys"] == "../keys" and saved["security"]["identity"] == "desk2"
    assert saved["tablet"]["tours"] is False


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "config: {latency_ceiling: 3}\n",
            r"station\.yaml: config\.latency_ceiling = 3 s is outside the allowed range "
            r"\[0\.05, 1\] s",
        ),
        ("config: {goal_tolerance: fast}\n", r"config\.goal_tolerance must be a number \[m\]"),
        ("tablet: {tours: 'no'}\n", r"tablet\.tours must be true or false, got 'no'"),
        ("tablet: {drive: true}\n", r"unknown key 'tablet\.drive' \(allowed: teleop, goals"),
        ("colour: red\n", r"unknown key 'colour' \(allowed: security, config, tablet\)"),
        ("config: [1\n", r"invalid YAML"),
    ],
)
def test_bad_values_stop_the_station_naming_file_key_and_range(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "station.yaml"
    path.write_text(text)
    with pytest.raises(StationFileError, match=message):
        StationSettingsStore(path).load()


def test_main_refuses_a_bad_station_file(tmp_path: Path, capsys) -> None:
    from base_station_app.main import main

    path = tmp_path / "station.yaml"
    path.write_text("config: {teleop_linear_max: 2.0}\n")
    assert main(["--config", str(path)]) == 2
    assert "config.teleop_linear_max = 2.0 m/s is outside" in capsys.readouterr().err


def test_a_file_that_cannot_be_written_is_reported(tmp_path: Path) -> None:
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("")
    store = StationSettingsStore(blocker / "station.yaml")
    with pytest.raises(StationFileError, match="cannot save the settings"):
        store.save(StationConfig(), EVERYTHING)


def test_panel_ranges_come_from_the_declaration() -> None:
    assert RANGES["latency_ceiling"] == (0.05, 1.0, "s")
    assert set(RANGES) == set(StationConfig.__struct_fields__)


def qsettings_keys(path: Path) -> set[str]:
    """The keys ``path`` reads or writes with QSettings ``value``/``setValue`` (on ``s``,
    ``settings``, ``self.settings`` or ``qsettings``, the names the station gives its QSettings)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    keys = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in {"value", "setValue"}
            and ast.unparse(node.func.value) in {"s", "settings", "self.settings", "qsettings"}
            and node.args
        ):
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                keys.add(arg.value)
            elif isinstance(arg, ast.JoinedStr | ast.Name | ast.Attribute):
                keys.add(ast.unparse(arg))
    return keys


# QSettings holds what is not configuration (docs/station_config.md): the window, and the robot
# the operator commanded last (a remembered choice, as a recent-files list; --robot overrides it).
# ``legacy_key``: `main.migrate_qsettings` reads the old config/* and tablet/* keys once, to move
# them into the station file and remove them.
QSETTINGS_ALLOWED = {"window/geometry", "window/state", "ROBOT_KEY", "legacy_key"}


def test_qsettings_hold_window_state_and_the_last_robot_only() -> None:
    used = set().union(*(qsettings_keys(p) for p in (REPO / "base_station_app").glob("*.py")))
    assert used and used <= QSETTINGS_ALLOWED, sorted(used - QSETTINGS_ALLOWED)


def test_qsettings_rule_catches_a_behaviour_setting(tmp_path: Path) -> None:
    bad = tmp_path / "main_window.py"
    bad.write_text('s.setValue(f"config/{name}", v)\nx = s.value("tablet/tours")\n')
    assert qsettings_keys(bad) - QSETTINGS_ALLOWED == {"f'config/{name}'", "tablet/tours"}


def test_old_qsettings_values_move_into_the_file_once(tmp_path: Path) -> None:
    """A station from before the station file kept config/* and tablet/* in QSettings: the
    first start moves them into the file (the file's own keys win), logs each, removes them."""
    from PySide6.QtCore import QSettings

    from base_station_app.main import migrate_qsettings

    path = tmp_path / "station.yaml"
    path.write_text("security: {identity: desk2}\nconfig: {goal_tolerance: 0.4}\n")
    old = QSettings(str(tmp_path / "BaseStation.conf"), QSettings.Format.IniFormat)
    for key, value in {
        "config/latency_ceiling": 0.3,
        "config/goal_tolerance": 0.9,  # the file sets it: the file wins
        "config/teleop_linear_max": 7.0,  # out of range: dropped, as the old station did
        "tablet/tours": False,
        "window/geometry": b"kept",
        "fleet/robot": "r2",
    }.items():
        old.setValue(key, value)
    old.sync()
    store = StationSettingsStore(path)
    migrate_qsettings(store, old)
    file = store.load()
    assert file.config.latency_ceiling == 0.3
    assert file.config.goal_tolerance == 0.4
    assert file.config.teleop_linear_max == StationConfig().teleop_linear_max
    assert file.tablet.permissions() == msgspec.structs.replace(EVERYTHING, tours=False)
    assert file.security.identity == "desk2"
    assert sorted(old.allKeys()) == ["fleet/robot", "window/geometry"]
    before = path.read_text(encoding="utf-8")
    migrate_qsettings(store, old)  # once: nothing left to move, the file is not touched
    assert path.read_text(encoding="utf-8") == before


def test_migration_notes_say_what_moved_and_what_was_dropped(tmp_path: Path) -> None:
    store = StationSettingsStore(tmp_path / "station.yaml")
    notes = migrate_legacy(
        store,
        {"config/yaw_tolerance": "0.5", "tablet/goals": "maybe", "config/speed": "1", "x/y": 1},
    )
    assert notes == [
        "config/speed = '1' dropped: unknown key 'config.speed' (allowed: "
        + ", ".join(StationConfig.__struct_fields__)
        + ")",
        f"config/yaw_tolerance = '0.5' moved to {store.path} as config.yaw_tolerance",
        "tablet/goals = 'maybe' dropped: tablet.goals must be true or false, got 'maybe'",
    ]
    assert store.load().config.yaw_tolerance == 0.5


def test_an_invalid_station_file_keeps_the_old_values(tmp_path: Path) -> None:
    from PySide6.QtCore import QSettings

    from base_station_app.main import migrate_qsettings

    path = tmp_path / "station.yaml"
    path.write_text("colour: red\n")
    old = QSettings(str(tmp_path / "BaseStation.conf"), QSettings.Format.IniFormat)
    old.setValue("config/latency_ceiling", 0.3)
    with pytest.raises(StationFileError, match="unknown key 'colour'"):
        migrate_qsettings(StationSettingsStore(path), old)
    assert old.allKeys() == ["config/latency_ceiling"]
