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
from pathlib import Path
from typing import ClassVar

import msgspec
import yaml

from base_station_app.station_config import StationConfig
from base_station_app.tablet_session import TabletPermissions
from interbot_core import schema

logger = logging.getLogger(__name__)

HEADER = (
    "# Interbot Base Station configuration (docs/station_config.md). The station rewrites\n"
    "# 'config' and 'tablet' when the operator applies a change; 'security' is only read.\n"
)


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

    def permissions(self) -> TabletPermissions:
        return TabletPermissions(self.teleop, self.goals, self.tours, self.requests)

    @classmethod
    def of(cls, permissions: TabletPermissions) -> TabletSection:
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

    def save(self, config: StationConfig, permissions: TabletPermissions) -> None:
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
