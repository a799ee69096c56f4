"""The robot daemon's configuration: ``robot.yaml`` declared as msgspec Structs (`RobotFile`).

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
    localiser: {map_surface: learn, help_after_s: 20, look_around: true}  # learn | cell_centre | cell_face
    rates: {controller_hz: 10, localiser_hz: 10, pose_hz: 20, scan_hz: 10, image_hz: 5}
    sim: {seed: 1, people: 4, odometry: calibrated, realtime_factor: 1.0}
    start_latched: true                 # start with the emergency stop latched (see below)
    recording: {directory: recordings, max_file_mb: 256, max_total_mb: 4096}  # MCAP (issue 18)

``start_latched`` (default true): after a (re)start the robot does not move until a station
that sees it releases the stop (a station re-asserts its operator's stop, or releases it, on
every connection). Set it false only for a robot that runs with no station at all.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any, ClassVar

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import SchemaError

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MAP = REPO_ROOT / "maps" / "isr_floor0.yaml"
DEFAULT_TOPO = REPO_ROOT / "maps" / "isr_floor0_topo.yaml"
DEFAULT_MUX = REPO_ROOT / "resources" / "config" / "interbot_mux.yaml"
DEFAULT_SAFETY = REPO_ROOT / "resources" / "config" / "collision_monitor.yaml"
ROBOT_ID_RE = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
ENDPOINT_RE = re.compile(r"^(?:tcp|tls)/(\[[0-9a-fA-F:]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")


class ConfigError(ValueError):
    """Invalid daemon configuration; the message names the source and the key."""


def _quoted(error: SchemaError) -> str:
    """``'sim.people' = -1 is outside ...``: the key quoted, as in every config message."""
    rest = error.message.removeprefix(error.path)
    return f"'{error.path}'{rest}" if rest != error.message else error.message


class Section(schema.Declared, frozen=True, kw_only=True):
    """A section of robot.yaml: its keys, types and ranges declared in its fields."""

    ERROR: ClassVar[type[Exception]] = ConfigError


Hz = Annotated[float, Meta(ge=0.1, le=100.0, extra={"unit": "Hz"})]


class Rates(Section, frozen=True):
    """Loop rates [Hz]. The controller and localiser run at 10 Hz by default (see mux config)."""

    ROOT: ClassVar[str] = "rates"
    controller_hz: Hz = 10.0
    localiser_hz: Hz = 10.0
    pose_hz: Hz = 20.0
    scan_hz: Hz = 10.0
    image_hz: Hz = 5.0
    battery_hz: Hz = 1.0
    status_hz: Hz = 2.0


class SimSettings(Section, frozen=True):
    ROOT: ClassVar[str] = "sim"
    seed: Annotated[int, Meta(ge=0)] = 1
    people: Annotated[int, Meta(ge=0, le=50)] = 4
    # perfect | calibrated (~3 %) | uncalibrated (~8 %)
    odometry: Annotated[str, schema.one_of("perfect", "calibrated", "uncalibrated")] = "calibrated"
    # daemon only: how fast simulated time runs against the wall
    realtime_factor: Annotated[float, Meta(ge=0.1, le=100.0)] = 1.0


Endpoint = Annotated[
    str, Meta(pattern=ENDPOINT_RE.pattern, extra={"format": "tcp/HOST:PORT or tls/HOST:PORT"})
]


class ZenohSettings(Section, frozen=True, kw_only=False):
    """``mode: peer`` (robots listen, stations connect to them) or ``client`` (both connect to
    a building's router, `interbot router`; a client does not listen)."""

    ROOT: ClassVar[str] = "zenoh"
    listen: tuple[Endpoint, ...] = ("tcp/127.0.0.1:7447",)
    connect: tuple[Endpoint, ...] = ()
    lease_ms: Annotated[int, Meta(ge=500, le=60_000, extra={"unit": "ms"})] = 2500
    mode: Annotated[str, schema.one_of("peer", "client")] = "peer"

    def check(self) -> None:
        for key in ("listen", "connect"):
            for endpoint in getattr(self, key):  # the form is the field's pattern
                if int(endpoint.rsplit(":", 1)[1]) > 65535:
                    raise ConfigError(f"zenoh: '{key}' port in {endpoint!r} is outside 0..65535")
        if not self.listen and not self.connect:
            raise ConfigError("zenoh: give at least one 'listen' or 'connect' endpoint")
        if self.mode == "client" and (self.listen or not self.connect):
            raise ConfigError(
                "zenoh: a client connects to a router and does not listen: "
                "give 'connect' (the router) and an empty 'listen'"
            )


MAP_SURFACES = ("learn", "cell_face", "cell_centre")


class LocaliserSettings(Section, frozen=True):
    """Where a wall lies in an occupied map cell, for the scan matcher: a property of the map,
    never chosen per backend (issue 12: the choice must not suit the simulator).

    ``learn`` (default): the robot finds it out from its own scans
    (`robot_daemon.localisation.wall_model`), matching through the cell centres until the
    evidence decides, then switching once. ``cell_centre``: fixed, through the cell, true on
    average for maps built from laser end points (SLAM: gmapping, Hector, Cartographer).
    ``cell_face``: fixed, on the cell's boundary with free space, for maps rasterised from a
    floor plan.
    """

    ROOT: ClassVar[str] = "localiser"
    map_surface: Annotated[str, schema.one_of(*MAP_SURFACES)] = "learn"
    # a global search undecided this long asks for "Help me!"
    help_after_s: Annotated[float, Meta(ge=0.0, le=3600.0, extra={"unit": "s"})] = 20.0
    # while a global search is undecided, turn in place (at most one turn) to see more
    look_around: bool = True


FilePath = Annotated[str, Meta(min_length=1, extra={"format": "a file path"})]


class SecuritySettings(Section, frozen=True, kw_only=False):
    """``security``: the key directory (mutual TLS + access control) or the insecure override.

    Without ``keys`` the daemon refuses endpoints off the loopback interface unless
    ``insecure`` (docs/security.md).
    """

    ROOT: ClassVar[str] = "security"
    keys: FilePath | None = None  # resolved against robot.yaml's folder by `parse_config`
    insecure: bool = False


MB = 1024 * 1024


class RecordingConfig(Section, frozen=True):
    """``recording:`` what the daemon records (MCAP, issue 18) and how much disk it may take::

    recording:
      directory: /var/lib/interbot/recordings   # relative to robot.yaml
      max_file_mb: 256        # rotate when the open file reaches this size
      max_file_minutes: 30    # ... or is this old (daemon time)
      max_total_mb: 4096      # oldest recordings are deleted first to stay under this
      camera: true            # record the camera (JPEG) as well
      queue: 2048             # messages waiting for the writer thread; beyond, drops are counted
    """

    ROOT: ClassVar[str] = "recording"
    directory: Annotated[str, Meta(min_length=1, extra={"format": "a directory path"})] | None = None  # fmt: skip
    max_file_mb: Annotated[float, Meta(ge=0.01, le=1 << 20)] = 256
    max_file_minutes: Annotated[float, Meta(ge=0.01, le=24 * 60)] = 30
    max_total_mb: Annotated[float, Meta(ge=0.02, le=1 << 24)] = 4096
    camera: bool = True
    queue: Annotated[int, Meta(ge=16, le=1 << 20)] = 2048

    def check(self) -> None:
        if self.max_total_mb < 2 * self.max_file_mb:
            raise ConfigError(
                f"recording: 'max_total_mb' ({self.max_total_mb:g}) must be at least twice "
                f"'max_file_mb' ({self.max_file_mb:g}): one file is being written while the "
                "older ones are kept"
            )

    @property
    def max_file_bytes(self) -> int:
        return int(self.max_file_mb * MB)

    @property
    def max_total_bytes(self) -> int:
        return int(self.max_total_mb * MB)

    @property
    def max_file_seconds(self) -> float:
        return self.max_file_minutes * 60.0


class RobotFile(Section, frozen=True):
    """The document robot.yaml, as written: every key optional, paths relative to the file."""

    ROOT: ClassVar[str] = ""
    robot_id: Annotated[str, Meta(pattern=ROBOT_ID_RE.pattern, extra={"format": "1-32 of A-Z a-z 0-9 _ -"})] = "interbot1"  # fmt: skip
    map: FilePath | None = None
    topo: FilePath | None = None
    mux: FilePath | None = None
    safety: FilePath | None = None
    backend: Annotated[str, schema.one_of("sim", "hardware")] = "sim"
    rates: Rates = msgspec.field(default_factory=Rates)
    sim: SimSettings = msgspec.field(default_factory=SimSettings)
    zenoh: ZenohSettings = msgspec.field(default_factory=ZenohSettings)
    localiser: LocaliserSettings = msgspec.field(default_factory=LocaliserSettings)
    security: SecuritySettings = msgspec.field(default_factory=SecuritySettings)
    hardware: dict[str, Any] = msgspec.field(default_factory=dict)  # checked by the drivers
    recording: RecordingConfig | None = None
    start_latched: bool = True


class DaemonConfig(RobotFile, frozen=True):
    """robot.yaml as loaded (`load_config`): its paths absolute, and the file's name."""

    source: str = "<defaults>"

    @property
    def map_yaml(self) -> Path:
        return Path(self.map) if self.map else DEFAULT_MAP

    @property
    def topo_yaml(self) -> Path:
        return Path(self.topo) if self.topo else DEFAULT_TOPO

    @property
    def mux_yaml(self) -> Path:
        return Path(self.mux) if self.mux else DEFAULT_MUX

    @property
    def safety_yaml(self) -> Path:
        """The collision monitor and assisted teleoperation (issue 17)."""
        return Path(self.safety) if self.safety else DEFAULT_SAFETY

    def with_overrides(self, **changes: Any) -> DaemonConfig:
        """A copy with command-line overrides applied (validated again)."""
        given = {k: v for k, v in changes.items() if v is not None}
        return DaemonConfig(**(msgspec.structs.asdict(self) | given))

    def summary(self) -> str:
        return (
            f"robot_id={self.robot_id} backend={self.backend} map={self.map_yaml} "
            f"topo={self.topo_yaml} listen={list(self.zenoh.listen)} "
            f"connect={list(self.zenoh.connect)} rates={self.rates} "
            f"security={self.security.keys or ('INSECURE' if self.security.insecure else 'off (loopback only)')} "
            f"start_latched={self.start_latched}"
        )


def parse_config(raw: Any, source: str, base_dir: Path) -> DaemonConfig:
    """Build a `DaemonConfig` from the parsed YAML mapping; paths are relative to base_dir."""
    if not isinstance(raw, dict | None):
        raise ConfigError(f"{source}: expected a mapping at the top level")
    try:
        doc = schema.convert(raw or {}, RobotFile, "")
        schema.check_all(doc)
    except SchemaError as exc:
        if exc.kind == "unknown":
            raise ConfigError(f"{source}: {exc.key_message()}") from None
        raise ConfigError(f"{source}: {_quoted(exc)}") from None
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None

    def path(value: str | None) -> str | None:
        return None if value is None else str((base_dir / value).resolve())

    paths = {key: path(getattr(doc, key)) for key in ("map", "topo", "mux", "safety")}
    fields = msgspec.structs.asdict(doc) | paths
    fields["security"] = msgspec.structs.replace(doc.security, keys=path(doc.security.keys))
    if doc.recording is not None:
        fields["recording"] = msgspec.structs.replace(
            doc.recording, directory=path(doc.recording.directory)
        )
    return DaemonConfig(**fields, source=source)


def load_config(path: str | Path) -> DaemonConfig:
    path = Path(path)
    raw = schema.read_yaml(path, ConfigError, "configuration")
    return parse_config(raw, str(path), path.parent)
