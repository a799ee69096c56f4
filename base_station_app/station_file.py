"""The station's configuration file, ``station.yaml``: the one owner of every station setting
that changes behaviour (issue 13; see docs/station_config.md).

    security: {keys: ../keys, identity: station, insecure: false, insecure_tablet: false}
    config:   {approach_tolerance: 0.7, goal_tolerance: 0.25, yaw_tolerance: 0.25,
               teleop_linear_max: 0.4, teleop_angular_max: 0.8, planner_linear_max: 0.25,
               planner_angular_max: 1.0, latency_ceiling: 0.5}
    tablet:   {teleop: true, goals: true, tours: true, requests: true}

Every section and key is optional (defaults as shown; ``keys`` is relative to the file). The file
is declared by `StationFile` (msgspec): a wrong key, type or value stops the station with a
message naming the file, the key, the value and what is allowed. The operator's changes in the
Configurations panel and the tablet permission boxes are written back to ``config:`` and
``tablet:`` at once (`StationSettingsStore.save`, atomically; comments are not kept); the
``security:`` section is only ever read. Window geometry and the robot commanded last are not
configuration: they stay in QSettings (docs/station_config.md says why).
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar, Final

import msgspec
import yaml

from base_station_app.station_config import StationConfig
from interbot_core import schema
from interbot_core.protocol import Permissions

logger = logging.getLogger(__name__)

HEADER = (
    "# Interbot Base Station configuration (docs/station_config.md). The station rewrites\n"
    "# 'config' and 'tablet' when the operator applies a change; 'security' is only read.\n"
)


LEGACY_PREFIXES: Final = ("config/", "tablet/")
"""QSettings keys of stations from before the station file (`migrate_legacy` moves them)."""


class StationFileError(ValueError):
    """The station file cannot be read, is invalid, or cannot be written; says which and why."""


class _Section(schema.Declared, frozen=True):
    ERROR: ClassVar[type[Exception]] = StationFileError


class SecuritySection(_Section, frozen=True):
    """``security:``: the key directory (relative to the file) and this station's identity."""

    ROOT: ClassVar[str] = "security"
    keys: str | None = None
    identity: str = "station"
    insecure: bool = False  # plaintext robot endpoints off the loopback interface
    insecure_tablet: bool = False  # the thesis's plaintext tablet protocol


class TabletSection(_Section, frozen=True):
    """``tablet:``: what the tablet may do (the Tablet panel's permission boxes)."""

    ROOT: ClassVar[str] = "tablet"
    teleop: bool = True
    goals: bool = True
    tours: bool = True
    requests: bool = True

    def permissions(self) -> Permissions:
        return Permissions(self.teleop, self.goals, self.tours, self.requests)

    @classmethod
    def of(cls, permissions: Permissions) -> TabletSection:
        return cls(permissions.teleop, permissions.goals, permissions.tours, permissions.requests)


class StationFile(_Section, frozen=True):
    ROOT: ClassVar[str] = ""
    security: SecuritySection = msgspec.field(default_factory=SecuritySection)
    config: StationConfig = msgspec.field(default_factory=StationConfig)
    tablet: TabletSection = msgspec.field(default_factory=TabletSection)


def default_path() -> Path:
    """``$XDG_CONFIG_HOME/interbot/station.yaml`` (``~/.config/...``), used without --config."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "interbot" / "station.yaml"


class StationSettingsStore:
    """Reads and writes one station file. A missing file is the defaults (written on save)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._security = SecuritySection()

    def load(self) -> StationFile:
        """The file's settings; raises `StationFileError` naming the file and the key."""
        if not self.path.exists():
            return StationFile()
        raw = schema.read_yaml(self.path, StationFileError, "station file")
        file = schema.load(raw or {}, StationFile, "", str(self.path), StationFileError)
        self._security = file.security
        return file

    def save(self, config: StationConfig, permissions: Permissions) -> None:
        """Write ``config`` and ``permissions`` (and the security section as read), atomically."""
        file = StationFile(self._security, config, TabletSection.of(permissions))
        text = HEADER + yaml.safe_dump(msgspec.to_builtins(file), sort_keys=False)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile(
                "w", encoding="utf-8", dir=self.path.parent, delete=False, suffix=".tmp"
            ) as out:
                out.write(text)
            os.replace(out.name, self.path)
        except OSError as exc:
            raise StationFileError(f"{self.path}: cannot save the settings: {exc}") from None


def _legacy_value(section: str, value: object) -> object:
    """A QSettings value as the file's type: QSettings gives back strings ("0.7", "true")."""
    if section == "tablet":
        truth = {"true": True, "1": True, "false": False, "0": False}
        return truth.get(str(value).lower(), value)
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return value


def migrate_legacy(store: StationSettingsStore, legacy: Mapping[str, object]) -> list[str]:
    """Move the QSettings values of stations from before the station file (``config/NAME``,
    ``tablet/KIND``) into the file, once, and return one line per value for the log.

    A key the file already sets keeps the file's value; a value that is invalid, or a name the
    file does not know, is dropped (the old station ignored those too). Raises
    `StationFileError` when the file is invalid or cannot be written: the caller then keeps the
    old values for the next start.
    """
    store.load()  # the security section, kept as read; refuses an invalid file
    raw: Any = (
        schema.read_yaml(store.path, StationFileError, "station file")
        if (store.path.exists())
        else {}
    )
    sections: dict[str, dict[str, object]] = {
        name: dict((raw or {}).get(name) or {}) for name in ("config", "tablet")
    }
    types: dict[str, type[msgspec.Struct]] = {"config": StationConfig, "tablet": TabletSection}
    notes = []
    for key, value in sorted(legacy.items()):
        section, _, name = key.partition("/")
        if section not in sections:
            continue
        if name in sections[section]:
            notes.append(f"{key} = {value!r} dropped: {store.path} sets {section}.{name}")
            continue
        candidate = _legacy_value(section, value)
        try:
            schema.convert({name: candidate}, types[section], section)
        except schema.SchemaError as exc:
            notes.append(f"{key} = {value!r} dropped: {exc.key_message()}")
            continue
        sections[section][name] = candidate
        notes.append(f"{key} = {value!r} moved to {store.path} as {section}.{name}")
    if any(" moved to " in note for note in notes):
        file = schema.load(sections, StationFile, "", str(store.path), StationFileError)
        store.save(file.config, file.tablet.permissions())
    return notes
