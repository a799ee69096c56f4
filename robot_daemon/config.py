"""The robot daemon's configuration: ``robot.yaml`` parsed into frozen, validated dataclasses.

Every error names the file and the key and says what is allowed; nothing half-applies. The
configuration is logged once at start-up. Example (all keys optional except where noted)::

    robot_id: interbot1
    map: ../maps/isr_floor0.yaml        # map_server YAML, relative to this file
    topo: ../maps/isr_floor0_topo.yaml  # topological map
    backend: sim                        # sim | hardware (hardware: issue 7)
    mux: ../resources/config/twist_mux.yaml
    safety: ../resources/config/collision_monitor.yaml  # collision monitor, assisted teleop
    zenoh: {listen: ["tcp/127.0.0.1:7447"], connect: []}  # tls/HOST:PORT with security
    security: {keys: /etc/interbot/keys, insecure: false}  # docs/security.md
    localiser: {map_surface: cell_centre, help_after_s: 20}  # surface: cell_centre | cell_face
    rates: {controller_hz: 10, localiser_hz: 10, pose_hz: 20, scan_hz: 10, image_hz: 5}
    sim: {seed: 1, people: 4, odometry: calibrated, realtime_factor: 1.0}
    start_latched: true                 # start with the emergency stop latched (see below)
    recording: {directory: recordings, max_file_mb: 256, max_total_mb: 4096}  # MCAP (issue 18)

``start_latched`` (default true): after a (re)start the robot does not move until a station
that sees it releases the stop (a station re-asserts its operator's stop, or releases it, on
every connection). Set it false only for a robot that runs with no station at all.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import yaml

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAP = REPO_ROOT / "maps" / "isr_floor0.yaml"
DEFAULT_TOPO = REPO_ROOT / "maps" / "isr_floor0_topo.yaml"
DEFAULT_MUX = REPO_ROOT / "resources" / "config" / "interbot_mux.yaml"
DEFAULT_SAFETY = REPO_ROOT / "resources" / "config" / "collision_monitor.yaml"
ROBOT_ID_RE = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
ENDPOINT_RE = re.compile(r"^(?:tcp|tls)/(\[[0-9a-fA-F:]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")


class ConfigError(ValueError):
    """Invalid daemon configuration; the message names the source and the key."""


def _number(source: str, key: str, value: Any, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{source}: '{key}' must be a number, got {value!r}")
    if not low <= value <= high:
        raise ConfigError(f"{source}: '{key}' = {value} is outside [{low}, {high}]")
    return float(value)


def validate_endpoint(source: str, key: str, endpoint: Any) -> str:
    """A zenoh ``tcp/HOST:PORT`` or ``tls/HOST:PORT`` endpoint (no scouting, no other protocols)."""
    if not isinstance(endpoint, str) or not (m := ENDPOINT_RE.match(endpoint)):
        raise ConfigError(
            f"{source}: '{key}' entry {endpoint!r} is not tcp/HOST:PORT or tls/HOST:PORT"
        )
    if not 0 <= int(m.group(2)) <= 65535:
        raise ConfigError(f"{source}: '{key}' port in {endpoint!r} is outside 0..65535")
    return endpoint


@dataclass(frozen=True)
class Rates:
    """Loop rates [Hz]. The controller and localiser run at 10 Hz by default (see mux config)."""

    controller_hz: float = 10.0
    localiser_hz: float = 10.0
    pose_hz: float = 20.0
    scan_hz: float = 10.0
    image_hz: float = 5.0
    battery_hz: float = 1.0
    status_hz: float = 2.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _number("rates", f.name, getattr(self, f.name), 0.1, 100.0)


@dataclass(frozen=True)
class SimSettings:
    seed: int = 1
    people: int = 4
    odometry: str = "calibrated"  # perfect | calibrated (~3 %) | uncalibrated (~8 %)
    realtime_factor: float = 1.0  # daemon only: how fast simulated time runs against the wall

    def __post_init__(self) -> None:
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError(f"sim: 'seed' must be a non-negative integer, got {self.seed!r}")
        if isinstance(self.people, bool) or not isinstance(self.people, int):
            raise ConfigError(f"sim: 'people' must be an integer, got {self.people!r}")
        if not 0 <= self.people <= 50:
            raise ConfigError(f"sim: 'people' = {self.people} is outside [0, 50]")
        if self.odometry not in ("perfect", "calibrated", "uncalibrated"):
            raise ConfigError(
                f"sim: 'odometry' must be perfect, calibrated or uncalibrated, got {self.odometry!r}"
            )
        _number("sim", "realtime_factor", self.realtime_factor, 0.1, 100.0)


@dataclass(frozen=True)
class ZenohSettings:
    """``mode: peer`` (robots listen, stations connect to them) or ``client`` (both connect to
    a building's router, `interbot router`; a client does not listen)."""

    listen: tuple[str, ...] = ("tcp/127.0.0.1:7447",)
    connect: tuple[str, ...] = ()
    lease_ms: int = 2500
    mode: str = "peer"

    def __post_init__(self) -> None:
        for key in ("listen", "connect"):
            for endpoint in getattr(self, key):
                validate_endpoint("zenoh", key, endpoint)
        if not self.listen and not self.connect:
            raise ConfigError("zenoh: give at least one 'listen' or 'connect' endpoint")
        _number("zenoh", "lease_ms", self.lease_ms, 500, 60_000)
        if self.mode not in ("peer", "client"):
            raise ConfigError(f"zenoh: mode must be 'peer' or 'client', got {self.mode!r}")
        if self.mode == "client" and (self.listen or not self.connect):
            raise ConfigError(
                "zenoh: a client connects to a router and does not listen: "
                "give 'connect' (the router) and an empty 'listen'"
            )


@dataclass(frozen=True)
class SecuritySettings:
    """``security``: the key directory (mutual TLS + access control) or the insecure override.

    Without ``keys`` the daemon refuses endpoints off the loopback interface unless
    ``insecure`` (docs/security.md).
    """

    keys: Path | None = None
    insecure: bool = False

    def __post_init__(self) -> None:
        if self.keys is not None and not isinstance(self.keys, Path):
            raise ConfigError(f"security: 'keys' must be a directory path, got {self.keys!r}")
        if not isinstance(self.insecure, bool):
            raise ConfigError(f"security: 'insecure' must be true or false, got {self.insecure!r}")


MAP_SURFACES = ("cell_face", "cell_centre")


@dataclass(frozen=True)
class LocaliserSettings:
    """Where a wall lies in an occupied map cell, for the scan matcher: ONE model for the map,
    whatever the backend (issue 12: the choice must not suit the simulator).

    ``cell_centre`` (default): through the cell, true on average for maps built from laser end
    points (SLAM: gmapping, Hector, Cartographer), the maps real robots use. ``cell_face``: on
    the cell's boundary with free space, for maps rasterised from a floor plan when the plan is
    known to be exact.
    """

    map_surface: str = "cell_centre"
    help_after_s: float = 20.0  # a global search undecided this long asks for "Help me!"

    def __post_init__(self) -> None:
        if not (
            isinstance(self.help_after_s, (int, float))
            and math.isfinite(self.help_after_s)
            and 0.0 <= self.help_after_s <= 3600.0
        ):
            raise ConfigError(
                f"localiser: 'help_after_s' must be in [0, 3600] s, got {self.help_after_s!r}"
            )
        if self.map_surface not in MAP_SURFACES:
            raise ConfigError(
                f"localiser: 'map_surface' must be cell_face or cell_centre, "
                f"got {self.map_surface!r}"
            )


@dataclass(frozen=True)
class DaemonConfig:
    robot_id: str = "interbot1"
    map_yaml: Path = DEFAULT_MAP
    topo_yaml: Path = DEFAULT_TOPO
    mux_yaml: Path = DEFAULT_MUX
    safety_yaml: Path = DEFAULT_SAFETY  # collision monitor + assisted teleop (issue 17)
    backend: str = "sim"
    rates: Rates = field(default_factory=Rates)
    sim: SimSettings = field(default_factory=SimSettings)
    zenoh: ZenohSettings = field(default_factory=ZenohSettings)
    localiser: LocaliserSettings = field(default_factory=LocaliserSettings)
    security: SecuritySettings = field(default_factory=SecuritySettings)
    hardware: dict[str, Any] = field(default_factory=dict)  # validated by the drivers (issue 7)
    recording: dict[str, Any] = field(default_factory=dict)  # robot_daemon/recording/config.py
    start_latched: bool = True  # stop latched at start until a station releases it
    source: str = "<defaults>"

    def __post_init__(self) -> None:
        if not isinstance(self.robot_id, str) or not ROBOT_ID_RE.match(self.robot_id):
            raise ConfigError(
                f"{self.source}: 'robot_id' {self.robot_id!r} must be 1-32 of A-Z a-z 0-9 _ -"
            )
        if not isinstance(self.start_latched, bool):
            raise ConfigError(
                f"{self.source}: 'start_latched' must be true or false, got {self.start_latched!r}"
            )
        if self.backend not in ("sim", "hardware"):
            raise ConfigError(
                f"{self.source}: 'backend' must be sim or hardware, got {self.backend!r}"
            )

    def with_overrides(self, **changes: Any) -> DaemonConfig:
        """A copy with command-line overrides applied (validated again)."""
        return replace(self, **{k: v for k, v in changes.items() if v is not None})

    def summary(self) -> str:
        return (
            f"robot_id={self.robot_id} backend={self.backend} map={self.map_yaml} "
            f"topo={self.topo_yaml} listen={list(self.zenoh.listen)} "
            f"connect={list(self.zenoh.connect)} rates={self.rates} "
            f"security={self.security.keys or ('INSECURE' if self.security.insecure else 'off (loopback only)')} "
            f"start_latched={self.start_latched}"
        )


_TOP_KEYS = {
    "robot_id",
    "map",
    "topo",
    "mux",
    "safety",
    "backend",
    "rates",
    "sim",
    "zenoh",
    "localiser",
    "hardware",
    "recording",
    "security",
    "start_latched",
}


def _section(source: str, raw: dict[str, Any], key: str, cls: type) -> Any:
    value = raw.get(key, {})
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: '{key}' must be a mapping")
    allowed = {f.name for f in fields(cls)}
    unknown = set(value) - allowed
    if unknown:
        raise ConfigError(
            f"{source}: unknown key(s) {sorted(unknown)} in '{key}' (allowed: {sorted(allowed)})"
        )
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in value.items()}
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    except TypeError as exc:
        raise ConfigError(f"{source}: '{key}': {exc}") from None


def parse_config(raw: Any, source: str, base_dir: Path) -> DaemonConfig:
    """Build a `DaemonConfig` from the parsed YAML mapping; paths are relative to base_dir."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level")
    unknown = set(raw) - _TOP_KEYS
    if unknown:
        raise ConfigError(
            f"{source}: unknown key(s) {sorted(unknown)} (allowed: {sorted(_TOP_KEYS)})"
        )

    def path(key: str, default: Path) -> Path:
        value = raw.get(key)
        if value is None:
            return default
        if not isinstance(value, str) or not value:
            raise ConfigError(f"{source}: '{key}' must be a file path")
        return (base_dir / value).resolve()

    security = raw.get("security", {})
    if not isinstance(security, dict) or set(security) - {"keys", "insecure"}:
        raise ConfigError(f"{source}: 'security' must be a mapping with 'keys' and/or 'insecure'")
    keys = security.get("keys")
    if keys is not None and (not isinstance(keys, str) or not keys):
        raise ConfigError(f"{source}: 'security.keys' must be a directory path")
    hardware = raw.get("hardware", {})
    if not isinstance(hardware, dict):
        raise ConfigError(f"{source}: 'hardware' must be a mapping")
    recording = raw.get("recording") or {}
    if not isinstance(recording, dict):
        raise ConfigError(f"{source}: 'recording' must be a mapping")
    return DaemonConfig(
        robot_id=raw.get("robot_id", "interbot1"),
        map_yaml=path("map", DEFAULT_MAP),
        topo_yaml=path("topo", DEFAULT_TOPO),
        mux_yaml=path("mux", DEFAULT_MUX),
        safety_yaml=path("safety", DEFAULT_SAFETY),
        backend=raw.get("backend", "sim"),
        rates=_section(source, raw, "rates", Rates),
        sim=_section(source, raw, "sim", SimSettings),
        zenoh=_section(source, raw, "zenoh", ZenohSettings),
        localiser=_section(source, raw, "localiser", LocaliserSettings),
        security=SecuritySettings(
            (base_dir / keys).resolve() if keys else None, security.get("insecure", False)
        ),
        hardware=hardware,
        recording=recording,
        start_latched=raw.get("start_latched", True),
        source=source,
    )


def load_config(path: str | Path) -> DaemonConfig:
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read configuration ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: invalid YAML ({exc})") from None
    return parse_config(raw, str(path), path.parent)
