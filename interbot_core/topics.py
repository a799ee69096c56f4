"""Zenoh key expressions and payload codecs for the robot <-> Base Station link.

The thesis (§4.2, §5.4, Figs. 5.13-5.14) connects the Base Station to the robot with ROS topics:
``station_vel``, ``tablet_vel`` and the ``pause_nav`` / ``stop`` locks into the twist multiplexer,
``cmd_vel`` out of it, ``scan``, ``map``, ``pose``, ``odom``, ``image``, the goal and the initial
pose. Interbot keeps those names as zenoh keys ``interbot/<robot_id>/<topic>`` and adds what the
thesis did over ad-hoc channels: ``route`` (the whole route, so the robot finishes it when the
station drops), ``route_progress``, ``battery``, ``status``, ``config`` (planner parameters on the
fly), ``mux`` (the active source), ``stop_release`` (the emergency stop latches on the robot),
the liveliness token ``interbot/<robot_id>/alive`` and the query ``interbot/<robot_id>/state``.

Control messages are compact JSON objects, one frozen msgspec Struct each whose field types
declare the rules (`interbot_core.schema`), validated on construction and on decoding. Scans, maps, images and the state snapshot are binary: a versioned header
(``struct``, little-endian) and a little-endian payload; layouts in docs/topics.md. Every decoder
rejects truncated, oversized, wrong-version or out-of-range payloads with `TopicDecodeError`, and
``decode(encode(m)) == m`` exactly (except the optional millimetre scan encoding, which rounds).

This module is pure: no zenoh, no I/O, no clock. `interbot_link` maps `TopicSpec` onto zenoh QoS.
"""

from __future__ import annotations

import enum
import logging
import math
import re
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Final, TypeVar

import msgspec
import numpy as np
from msgspec import Meta

from interbot_core import schema
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid

logger = logging.getLogger(__name__)

KEY_PREFIX: Final = "interbot"
ROBOT_ID_PATTERN: Final = re.compile(r"[A-Za-z0-9_-]{1,32}")
ALIVE: Final = "alive"
STATE_QUERY: Final = "state"
ALIVE_WILDCARD: Final = f"{KEY_PREFIX}/*/{ALIVE}"

MAX_JSON_BYTES: Final = 256 * 1024
"""Largest accepted JSON payload [bytes] (a 1024-waypoint route is about 70 KiB)."""
MAX_LIST_LENGTH: Final = 1024
"""Most waypoints in a route, locks in a mux report, parameters in a config message."""
MAX_TEXT: Final = 1024
"""Longest free-text field [characters]."""
ROUTE_ID_MAX: Final = 2**63 - 1  # route ids are random 63-bit numbers (unique across restarts)
MAX_COORD: Final = 1.0e6  # [m] bound on map coordinates
MAX_LINEAR: Final = 5.0  # [m/s] bound on any linear velocity on the wire
MAX_ANGULAR: Final = 2.0 * math.pi  # [rad/s]
MAX_SCAN_BEAMS: Final = 16384
MAX_MAP_CELLS: Final = 8192 * 8192
MAX_IMAGE_BYTES: Final = 8 * 1024 * 1024
MAX_SNAPSHOT_BYTES: Final = 80 * 1024 * 1024

BINARY_MAGIC: Final = b"IB"
BINARY_VERSION: Final = 1


class TopicError(ValueError):
    """Base class: a key or message of the zenoh link is invalid."""


class RobotIdError(TopicError):
    """A robot id does not match ``[A-Za-z0-9_-]{1,32}``."""


class MessageValueError(TopicError):
    """A message was built with a field out of its allowed range (a bug on the sending side)."""


class TopicDecodeError(TopicError):
    """A received payload is malformed; the message names the topic and the field."""


# --------------------------------------------------------------------------- keys


class Topic(enum.StrEnum):
    """The topic names after ``interbot/<robot_id>/``."""

    # Commands, Base Station (or tablet via the station) -> robot.
    STATION_VEL = "station_vel"
    TABLET_VEL = "tablet_vel"
    PAUSE_NAV = "pause_nav"
    STOP = "stop"
    STOP_RELEASE = "stop_release"
    ROUTE = "route"
    ROUTE_CANCEL = "route_cancel"
    GOAL = "goal"
    INITIAL_POSE = "initial_pose"
    RELOCALISE = "relocalise"
    CONFIG = "config"
    TELEOP_ASSIST = "teleop_assist"
    # State, robot -> Base Station.
    CMD_VEL = "cmd_vel"
    POSE = "pose"
    ODOM = "odom"
    SCAN = "scan"
    MAP = "map"
    ROUTE_PROGRESS = "route_progress"
    IMAGE = "image"
    BATTERY = "battery"
    STATUS = "status"
    MUX = "mux"
    PLAN = "plan"
    SAFETY = "safety"
    NOTICES = "notices"


def validate_robot_id(robot_id: str) -> str:
    """Return ``robot_id`` if it is 1-32 characters of ``[A-Za-z0-9_-]``, else raise RobotIdError."""
    if not isinstance(robot_id, str) or ROBOT_ID_PATTERN.fullmatch(robot_id) is None:
        raise RobotIdError(
            f"robot id {robot_id!r} is invalid: use 1-32 characters from A-Z a-z 0-9 _ -"
        )
    return robot_id


def key(robot_id: str, topic: Topic | str) -> str:
    """The key expression ``interbot/<robot_id>/<topic>`` (topic may be ``alive`` or ``state``)."""
    name = str(topic)
    if name not in _TOPIC_NAMES and name not in (ALIVE, STATE_QUERY):
        raise TopicError(f"unknown topic {name!r}; known: {sorted(_TOPIC_NAMES)}")
    return f"{KEY_PREFIX}/{validate_robot_id(robot_id)}/{name}"


def alive_key(robot_id: str) -> str:
    """The liveliness token key ``interbot/<robot_id>/alive``."""
    return key(robot_id, ALIVE)


def state_key(robot_id: str) -> str:
    """The state query key ``interbot/<robot_id>/state``."""
    return key(robot_id, STATE_QUERY)


def robot_wildcard(robot_id: str) -> str:
    """``interbot/<robot_id>/*``: every topic of one robot."""
    return f"{KEY_PREFIX}/{validate_robot_id(robot_id)}/*"


def parse_key(key_expr: str) -> tuple[str, str]:
    """Split ``interbot/<robot_id>/<name>`` into (robot_id, name); raise TopicError otherwise."""
    parts = str(key_expr).split("/")
    if len(parts) != 3 or parts[0] != KEY_PREFIX:
        raise TopicError(f"key {key_expr!r} is not of the form {KEY_PREFIX}/<robot_id>/<topic>")
    return validate_robot_id(parts[1]), parts[2]


# --------------------------------------------------------------------------- field types

MAX_POSE_VARIANCE: Final = 1.0e6  # [m², rad²] bound on a covariance entry
MAX_SAFETY_DISTANCE: Final = 1000.0  # [m] "nothing near" is sent as this (JSON has no inf)

Coord = Annotated[float, Meta(ge=-MAX_COORD, le=MAX_COORD, extra={"unit": "m"})]
Yaw = Annotated[float, Meta(ge=-math.pi, le=math.pi, extra={"unit": "rad"})]
Linear = Annotated[float, Meta(ge=-MAX_LINEAR, le=MAX_LINEAR, extra={"unit": "m/s"})]
Angular = Annotated[float, Meta(ge=-MAX_ANGULAR, le=MAX_ANGULAR, extra={"unit": "rad/s"})]
Stamp = Annotated[float, Meta(ge=0.0, le=1.0e12, extra={"unit": "s"})]
Share = Annotated[float, Meta(ge=0.0, le=1.0)]
Text = Annotated[str, Meta(max_length=MAX_TEXT)]
RouteId = Annotated[int, Meta(ge=0, le=ROUTE_ID_MAX)]
NodeId = Annotated[int, Meta(ge=0, le=2**31 - 1)]
Tolerance = Annotated[float, Meta(ge=1e-3, le=100.0, extra={"unit": "m"})]
YawTolerance = Annotated[float, Meta(ge=1e-3, le=math.pi, extra={"unit": "rad"})]
Variance = Annotated[float, Meta(ge=-MAX_POSE_VARIANCE, le=MAX_POSE_VARIANCE)]
SafetyDistance = Annotated[float, Meta(ge=0.0, le=MAX_SAFETY_DISTANCE, extra={"unit": "m"})]


# --------------------------------------------------------------------------- JSON messages


class Checked(schema.Declared, frozen=True):
    """Base of the messages: a typed declaration whose field types carry the constraints.

    msgspec checks them on decoding, `schema.Declared` on construction (MessageValueError
    naming ``Class.field``); ``check`` holds the rules that relate fields to each other.
    """

    ERROR: ClassVar[type[Exception]] = MessageValueError

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.ROOT = cls.__name__  # errors name the message: "Twist.linear = 9.0 m/s is ..."


class JsonMessage(Checked, frozen=True):
    """A message sent as one JSON object of its fields."""


class Twist(JsonMessage, frozen=True):
    """A velocity command or report: ``linear`` [m/s] forward, ``angular`` [rad/s] CCW."""

    linear: Linear
    angular: Angular
    stamp: Stamp = 0.0  # sender's clock


class Lock(JsonMessage, frozen=True):
    """A multiplexer lock value (``pause_nav``, ``stop``): engaged masks lower priorities."""

    engaged: bool
    stamp: Stamp = 0.0


class StopRelease(JsonMessage, frozen=True):
    """Release the latched emergency stop; ``operator`` names who released it (for the log)."""

    operator: Text = ""
    stamp: Stamp = 0.0


POSE_STATES: Final = ("unset", "ok", "degraded", "lost", "searching", "turning")
PoseState = Annotated[str, schema.one_of(*POSE_STATES)]


class PoseMsg(JsonMessage, frozen=True):
    """The localiser's pose in the ``map`` frame.

    ``state``: unset (no initial pose), ok, degraded (tracking, but uncertain or the last
    scans disagree with the map: drive slowly), lost, searching (global localisation), turning
    (searching while it turns in place to see more: `robot_daemon.localisation.look_around`).
    ``covariance``: 3x3 of (x [m], y [m], yaw [rad]), row-major (ROS's
    ``PoseWithCovariance`` restricted to the plane), or empty when not reported.
    ``x, y, yaw`` mean nothing when the state is unset, or when a search (searching, turning)
    runs before the robot had any pose (start-up): then the confidence is 0 and the covariance
    empty (`known`).
    """

    x: Coord
    y: Coord
    yaw: Yaw
    stamp: Stamp = 0.0
    state: PoseState = "ok"
    confidence: Share = 1.0
    covariance: Annotated[tuple[Variance, ...], Meta(max_length=9)] = ()

    def check(self) -> None:
        cov = self.covariance
        if len(cov) not in (0, 9):
            raise MessageValueError("PoseMsg.covariance must be a list of 0 or 9 numbers")
        if cov and min(cov[0], cov[4], cov[8]) < 0.0:
            raise MessageValueError("PoseMsg.covariance: the diagonal must be >= 0")

    @property
    def known(self) -> bool:
        """Whether ``x, y, yaw`` are a pose (see the class docstring)."""
        if self.state == "unset":
            return False
        searching = self.state in ("searching", "turning")
        return not (searching and self.confidence == 0.0 and not self.covariance)

    @property
    def sigmas(self) -> tuple[float, float, float] | None:
        """Standard deviations of x [m], y [m], yaw [rad]; None when no covariance."""
        if not self.covariance:
            return None
        c = self.covariance
        return (math.sqrt(c[0]), math.sqrt(c[4]), math.sqrt(c[8]))


class Odom(JsonMessage, frozen=True):
    """Wheel odometry in the ``odom`` frame and the measured velocities."""

    x: Coord
    y: Coord
    yaw: Yaw
    linear: Linear = 0.0
    angular: Angular = 0.0
    stamp: Stamp = 0.0


class RouteMsg(JsonMessage, frozen=True):
    """A whole route: waypoints ``(x, y, yaw)`` in the ``map`` frame, the last one the goal.

    ``node_ids`` are the topological nodes of the waypoints (empty, or one per waypoint);
    ``approach_tolerance`` [m] is how close an intermediate waypoint must be reached,
    ``goal_tolerance`` [m] and ``yaw_tolerance`` [rad] apply to the final one.
    """

    route_id: RouteId
    waypoints: Annotated[
        tuple[tuple[Coord, Coord, Yaw], ...], Meta(min_length=1, max_length=MAX_LIST_LENGTH)
    ]
    node_ids: Annotated[tuple[NodeId, ...], Meta(max_length=MAX_LIST_LENGTH)] = ()
    approach_tolerance: Tolerance = 0.7
    goal_tolerance: Tolerance = 0.25
    yaw_tolerance: YawTolerance = 0.25

    def check(self) -> None:
        if len(self.node_ids) not in (0, len(self.waypoints)):
            raise MessageValueError(
                f"RouteMsg.node_ids must be empty or hold one id per waypoint "
                f"({len(self.waypoints)}), got {len(self.node_ids)}"
            )


class RouteCancel(JsonMessage, frozen=True):
    """Drop route ``route_id`` (or whatever route is in progress when it is None)."""

    route_id: RouteId | None = None
    reason: Text = ""
    stamp: Stamp = 0.0


ROUTE_STATES: Final = ("idle", "active", "paused", "succeeded", "aborted", "canceled")
RouteState = Annotated[str, schema.one_of(*ROUTE_STATES)]


class RouteProgress(JsonMessage, frozen=True):
    """Progress on route ``route_id``: heading for waypoint ``index``; why it ended, if it did."""

    route_id: RouteId
    index: Annotated[int, Meta(ge=0, le=MAX_LIST_LENGTH)]
    reached_final: bool = False
    state: RouteState = "active"
    reason: Text = ""
    stamp: Stamp = 0.0


class GoalMsg(JsonMessage, frozen=True):
    """Go to a map point, or to topological node ``node_id`` (then x, y, yaw are its pose)."""

    x: Coord
    y: Coord
    yaw: Yaw
    node_id: NodeId | None = None
    stamp: Stamp = 0.0


class InitialPose(JsonMessage, frozen=True):
    """Set the localiser's pose (RViz's "2D Pose Estimate", the tablet's "Help me!").

    ``verify``: the pose is only a hint (a room picked by a person): the robot searches around
    it and applies it only if the laser confirms it."""

    x: Coord
    y: Coord
    yaw: Yaw
    stamp: Stamp = 0.0
    verify: bool = False


class Relocalise(JsonMessage, frozen=True):
    """Ask the robot to find itself on the whole map (global localisation, issue 16)."""

    stamp: Stamp = 0.0


class Battery(JsonMessage, frozen=True):
    """BMS reading: ``voltage`` [V], ``current`` [A] (positive = discharging), ``soc`` [0, 1]."""

    voltage: Annotated[float, Meta(ge=0.0, le=1000.0, extra={"unit": "V"})]
    current: Annotated[float, Meta(ge=-1000.0, le=1000.0, extra={"unit": "A"})] = 0.0
    soc: Share = 1.0
    stamp: Stamp = 0.0


STATUS_LEVELS: Final = ("info", "warning", "error")
StatusLevel = Annotated[str, schema.one_of(*STATUS_LEVELS)]


class Status(JsonMessage, frozen=True):
    """What the Base Station UI shows (thesis §5.2.1): the task, a message, distance to go."""

    level: StatusLevel
    text: Text
    task: Text = ""
    distance_to_goal: Annotated[float, Meta(ge=0.0, le=1.0e7, extra={"unit": "m"})] | None = None
    stamp: Stamp = 0.0


MAX_NOTICES: Final = 16


class StandingNotices(JsonMessage, frozen=True):
    """The robot's standing notices: status lines that stay true once said (the wall model its
    localiser learnt, ...), oldest first. A station that joins later reads them from the
    snapshot, which keeps only the newest status line of its own."""

    items: Annotated[tuple[Status, ...], Meta(max_length=MAX_NOTICES)] = ()


ParamName = Annotated[str, Meta(pattern=r"^[a-z_][a-z0-9_.]{0,63}$")]
ParamValue = bool | int | schema.Finite | Text


class ConfigMsg(JsonMessage, frozen=True):
    """Planner parameters changed on the fly: ``{name: value}``, values bool, int, float or str."""

    params: Annotated[dict[ParamName, ParamValue], Meta(min_length=1, max_length=MAX_LIST_LENGTH)]


class MuxMsg(JsonMessage, frozen=True):
    """The velocity multiplexer's output: winning ``source`` (None: explicit zero) and why."""

    source: Text | None
    reason: Text = ""
    active_locks: Annotated[tuple[Text, ...], Meta(max_length=MAX_LIST_LENGTH)] = ()
    linear: Linear = 0.0
    angular: Angular = 0.0
    stamp: Stamp = 0.0


class PlanMsg(JsonMessage, frozen=True):
    """The navigator's global path in the ``map`` frame, as planned (empty: no path).

    ``route_id`` is the route it serves (0: none); ``points`` are ``(x, y)`` [m], thinned by the
    robot to at most `MAX_LIST_LENGTH` so the station draws what the robot will drive, not
    straight lines between the route's waypoints.
    """

    route_id: RouteId
    points: Annotated[tuple[tuple[Coord, Coord], ...], Meta(max_length=MAX_LIST_LENGTH)]
    stamp: Stamp = 0.0


TELEOP_INPUT_TOPICS: Final = ("station_vel", "tablet_vel")
TeleopInput = Annotated[str, schema.one_of(*TELEOP_INPUT_TOPICS)]
SAFETY_ZONES: Final = ("none", "slowdown", "limit", "approach", "stop", "no_data")
SafetyZone = Annotated[str, schema.one_of(*SAFETY_ZONES)]


class AssistMsg(JsonMessage, frozen=True):
    """Assisted teleoperation on/off for one joystick input (``station_vel`` / ``tablet_vel``)."""

    input: TeleopInput
    enabled: bool
    stamp: Stamp = 0.0


class SafetyMsg(JsonMessage, frozen=True):
    """The collision monitor's state for the person driving (issue 17; NOT a certified safety
    function): the most restrictive active ``zone`` and its name, the distance [m] from the
    footprint to the nearest laser return and the time to contact [s] along the commanded arc
    (``MAX_SAFETY_DISTANCE`` when none), the share of the commanded speed let through, the
    inputs with assisted teleoperation on, and what the assistance did last."""

    zone: SafetyZone
    zone_name: Text = ""
    distance: SafetyDistance = MAX_SAFETY_DISTANCE
    time_to_contact: Annotated[float, Meta(ge=0.0, le=MAX_SAFETY_DISTANCE)] = MAX_SAFETY_DISTANCE
    scale: Share = 1.0
    assisted: tuple[TeleopInput, ...] = ()
    assist_mode: Annotated[str, schema.one_of("idle", "free", "scaled", "slid", "stopped")] = "idle"
    stamp: Stamp = 0.0


_JSON_ENCODER: Final = msgspec.json.Encoder()


M = TypeVar("M", bound=JsonMessage)


def decode_json(cls: type[M], payload: bytes, topic: str = "") -> M:
    """Parse and validate ``payload`` as ``cls``; raise TopicDecodeError naming the topic.

    Duplicate keys are refused (``{"linear":0.1,"linear":4.9}``), as on the tablet's TCP link.
    """
    where = topic or cls.__name__
    if len(payload) > MAX_JSON_BYTES:
        raise TopicDecodeError(f"{where}: payload of {len(payload)} bytes > {MAX_JSON_BYTES}")
    try:
        message = schema.convert(schema.parse_json(bytes(payload)), cls, cls.__name__)
        message.check()
    except ValueError as exc:  # JsonSyntaxError, SchemaError, MessageValueError
        raise TopicDecodeError(f"{where}: {exc}") from None
    return message


# --------------------------------------------------------------------------- binary messages


class BinaryKind(enum.IntEnum):
    """The ``kind`` byte of a binary header."""

    SCAN = 1
    MAP = 2
    IMAGE = 3
    SNAPSHOT = 4


_PREAMBLE = struct.Struct("<2sBB")  # magic, version, kind


def _check_preamble(payload: bytes, kind: BinaryKind, what: str) -> None:
    if len(payload) < _PREAMBLE.size:
        raise TopicDecodeError(f"{what}: truncated header ({len(payload)} bytes)")
    magic, version, got = _PREAMBLE.unpack_from(payload)
    if magic != BINARY_MAGIC:
        raise TopicDecodeError(f"{what}: bad magic {magic!r}, expected {BINARY_MAGIC!r}")
    if version != BINARY_VERSION:
        raise TopicDecodeError(f"{what}: version {version} unsupported (this is {BINARY_VERSION})")
    if got != kind:
        raise TopicDecodeError(f"{what}: payload kind {got}, expected {int(kind)} ({kind.name})")


class RangeEncoding(enum.IntEnum):
    """How scan ranges are stored: float32 metres (exact) or uint16 millimetres (0 = no return)."""

    FLOAT32 = 0
    UINT16_MM = 1


# preamble, stamp, angle_min, angle_increment, range_min, range_max, range_encoding, count
_SCAN = struct.Struct("<2sBBdddddBI")


def encode_scan(scan: LaserScan, encoding: RangeEncoding = RangeEncoding.FLOAT32) -> bytes:
    """Binary scan: header then ``count`` little-endian float32 [m] or uint16 [mm] ranges.

    In millimetres a beam without a usable return (non-finite or outside [range_min,
    range_max], or beyond 65.534 m) is stored as 0 and decodes as NaN.
    """
    if scan.ranges.size > MAX_SCAN_BEAMS:
        raise MessageValueError(f"scan has {scan.ranges.size} beams > {MAX_SCAN_BEAMS}")
    head = _SCAN.pack(
        BINARY_MAGIC,
        BINARY_VERSION,
        BinaryKind.SCAN,
        scan.stamp,
        scan.angle_min,
        scan.angle_increment,
        scan.range_min,
        scan.range_max,
        encoding,
        scan.ranges.size,
    )
    if encoding == RangeEncoding.FLOAT32:
        body = scan.ranges.astype("<f4", copy=False).tobytes()
    else:
        mm = np.zeros(scan.ranges.size, dtype="<u2")
        valid = scan.valid()
        mm_f = np.round(scan.ranges[valid].astype(np.float64) * 1000.0)
        mm[valid] = np.where(mm_f <= 65534, mm_f, 0).astype("<u2")
        body = mm.tobytes()
    return head + body


def decode_scan(payload: bytes) -> LaserScan:
    """Inverse of `encode_scan`."""
    payload = bytes(payload)
    _check_preamble(payload, BinaryKind.SCAN, "scan")
    if len(payload) < _SCAN.size:
        raise TopicDecodeError(f"scan: truncated header ({len(payload)} < {_SCAN.size} bytes)")
    _, _, _, stamp, amin, ainc, rmin, rmax, enc, count = _SCAN.unpack_from(payload)
    if enc not in (RangeEncoding.FLOAT32, RangeEncoding.UINT16_MM):
        raise TopicDecodeError(f"scan: unknown range encoding {enc}")
    if not 1 <= count <= MAX_SCAN_BEAMS:
        raise TopicDecodeError(f"scan: beam count {count} outside 1..{MAX_SCAN_BEAMS}")
    width = 4 if enc == RangeEncoding.FLOAT32 else 2
    expected = _SCAN.size + count * width
    if len(payload) != expected:
        raise TopicDecodeError(f"scan: {len(payload)} bytes, expected {expected} for {count} beams")
    for name, value in (("stamp", stamp), ("angle_min", amin), ("range_max", rmax)):
        if not math.isfinite(value):
            raise TopicDecodeError(f"scan: {name} is not finite")
    if enc == RangeEncoding.FLOAT32:
        ranges = np.frombuffer(payload, dtype="<f4", offset=_SCAN.size).astype(np.float32)
    else:
        mm = np.frombuffer(payload, dtype="<u2", offset=_SCAN.size)
        ranges = np.where(mm == 0, np.nan, mm.astype(np.float64) / 1000.0).astype(np.float32)
    try:
        return LaserScan(stamp, amin, ainc, rmin, rmax, ranges)
    except ValueError as exc:
        raise TopicDecodeError(f"scan: {exc}") from exc


# preamble, resolution, origin_x, origin_y, origin_yaw, width, height, compressed length
_MAP = struct.Struct("<2sBBddddIII")


def encode_map(grid: OccupancyGrid, level: int = 6) -> bytes:
    """Binary map: header then zlib-compressed int8 cells, row-major, row 0 at the bottom."""
    body = zlib.compress(grid.cells.astype(np.int8, copy=False).tobytes(), level)
    head = _MAP.pack(
        BINARY_MAGIC,
        BINARY_VERSION,
        BinaryKind.MAP,
        grid.resolution,
        grid.origin_x,
        grid.origin_y,
        grid.origin_yaw,
        grid.width,
        grid.height,
        len(body),
    )
    return head + body


def decode_map(payload: bytes, source: str = "zenoh map") -> OccupancyGrid:
    """Inverse of `encode_map`; cells must be -1 (unknown) or 0..100 (nav_msgs/OccupancyGrid)."""
    payload = bytes(payload)
    _check_preamble(payload, BinaryKind.MAP, "map")
    if len(payload) < _MAP.size:
        raise TopicDecodeError(f"map: truncated header ({len(payload)} < {_MAP.size} bytes)")
    _, _, _, res, ox, oy, oyaw, width, height, clen = _MAP.unpack_from(payload)
    cells_n = width * height
    if not 1 <= cells_n <= MAX_MAP_CELLS:
        raise TopicDecodeError(f"map: {width}x{height} cells outside 1..{MAX_MAP_CELLS}")
    if len(payload) != _MAP.size + clen:
        raise TopicDecodeError(f"map: {len(payload)} bytes, header says {_MAP.size + clen}")
    inflater = zlib.decompressobj()
    try:
        raw = inflater.decompress(payload[_MAP.size :], cells_n + 1)
    except zlib.error as exc:
        raise TopicDecodeError(f"map: corrupt zlib data ({exc})") from exc
    if len(raw) != cells_n or not inflater.eof or inflater.unconsumed_tail or inflater.unused_data:
        raise TopicDecodeError(f"map: cell data does not hold exactly {width}x{height} cells")
    cells = np.frombuffer(raw, dtype=np.int8).reshape(height, width)
    if cells.min() < -1 or cells.max() > 100:
        raise TopicDecodeError("map: cell values must be -1 (unknown) or 0..100")
    if not math.isfinite(oyaw):
        raise TopicDecodeError("map: origin_yaw is not finite")
    try:
        return OccupancyGrid(cells, res, ox, oy, oyaw, source)
    except ValueError as exc:
        raise TopicDecodeError(f"map: {exc}") from exc


JPEG_SOI: Final = b"\xff\xd8"


class ImageMsg(Checked, frozen=True):
    """A camera frame: JPEG bytes of a ``width`` x ``height`` image taken at ``stamp`` [s]."""

    stamp: Stamp
    width: Annotated[int, Meta(ge=1, le=65535)]
    height: Annotated[int, Meta(ge=1, le=65535)]
    jpeg: Annotated[bytes, Meta(max_length=MAX_IMAGE_BYTES)]

    def check(self) -> None:
        if not self.jpeg.startswith(JPEG_SOI):
            raise MessageValueError("ImageMsg.jpeg must be JPEG bytes (starting FF D8)")

    def __repr__(self) -> str:
        return f"ImageMsg(stamp={self.stamp}, width={self.width}, height={self.height})"


def encode_image(image: ImageMsg) -> bytes:
    """Binary image: the preamble, then a MessagePack map of the fields (the JPEG as bin)."""
    preamble = _PREAMBLE.pack(BINARY_MAGIC, BINARY_VERSION, BinaryKind.IMAGE)
    return preamble + msgspec.msgpack.encode(image)


def decode_image(payload: bytes) -> ImageMsg:
    """Inverse of `encode_image`; the fields are checked as the declaration says."""
    payload = bytes(payload)
    if len(payload) > MAX_IMAGE_BYTES + 64:  # the JPEG and a few bytes of fields
        raise TopicDecodeError(f"image: {len(payload)} bytes, more than a JPEG may have")
    _check_preamble(payload, BinaryKind.IMAGE, "image")
    try:
        fields = msgspec.msgpack.decode(payload[_PREAMBLE.size :])
        image = schema.convert(fields, ImageMsg, "image")
        image.check()
    except (msgspec.DecodeError, ValueError) as exc:  # truncated, SchemaError, not JPEG
        raise TopicDecodeError(f"image: {exc}") from None
    return image


# --------------------------------------------------------------------------- topic table


@dataclass(frozen=True)
class TopicSpec:
    """How a topic travels: direction, encoding and delivery class.

    ``must_arrive`` topics are sent with congestion control BLOCK (never dropped in a full
    queue); ``latest_only`` topics are consumed newest-value-first (a ring of one).
    """

    topic: Topic
    command: bool  # True: station -> robot; False: robot -> station
    binary: bool
    must_arrive: bool
    latest_only: bool
    message_type: type


_SPECS: Final = (
    TopicSpec(Topic.STATION_VEL, True, False, False, True, Twist),  # Base Station teleoperation (mux priority 100)
    TopicSpec(Topic.TABLET_VEL, True, False, False, True, Twist),  # tablet joystick via the station (mux priority 50)
    TopicSpec(Topic.PAUSE_NAV, True, False, True, False, Lock),  # pause/resume navigation lock (priority 25)
    TopicSpec(Topic.STOP, True, False, True, False, Lock),  # emergency stop lock (priority 255, latches)
    TopicSpec(Topic.STOP_RELEASE, True, False, True, False, StopRelease),  # release the latched emergency stop
    TopicSpec(Topic.ROUTE, True, False, True, False, RouteMsg),  # whole route to follow
    TopicSpec(Topic.ROUTE_CANCEL, True, False, True, False, RouteCancel),  # drop the route in progress
    TopicSpec(Topic.GOAL, True, False, True, False, GoalMsg),  # single goal; the robot plans the route
    TopicSpec(Topic.INITIAL_POSE, True, False, True, False, InitialPose),  # set the localiser's pose
    TopicSpec(Topic.RELOCALISE, True, False, True, False, Relocalise),  # find the robot on the whole map
    TopicSpec(Topic.CONFIG, True, False, True, False, ConfigMsg),  # planner parameters on the fly
    TopicSpec(Topic.TELEOP_ASSIST, True, False, True, False, AssistMsg),  # assisted teleoperation on/off per joystick input
    TopicSpec(Topic.CMD_VEL, False, False, False, True, Twist),  # mux output sent to the motors
    TopicSpec(Topic.POSE, False, False, False, True, PoseMsg),  # localised pose in the map frame
    TopicSpec(Topic.ODOM, False, False, False, True, Odom),  # wheel odometry
    TopicSpec(Topic.SCAN, False, True, False, True, LaserScan),  # laser scan (binary)
    TopicSpec(Topic.MAP, False, True, False, False, OccupancyGrid),  # occupancy grid (binary, zlib)
    TopicSpec(Topic.ROUTE_PROGRESS, False, False, True, False, RouteProgress),  # route/goal status
    TopicSpec(Topic.IMAGE, False, True, False, True, ImageMsg),  # camera frame (binary JPEG)
    TopicSpec(Topic.BATTERY, False, False, False, True, Battery),  # battery state
    TopicSpec(Topic.STATUS, False, False, True, False, Status),  # status text for the UI
    TopicSpec(Topic.MUX, False, False, False, True, MuxMsg),  # active velocity source
    TopicSpec(Topic.PLAN, False, False, False, True, PlanMsg),  # the navigator's global path
    TopicSpec(Topic.SAFETY, False, False, False, True, SafetyMsg),  # collision monitor zone, distance, assistance
    TopicSpec(Topic.NOTICES, False, False, True, False, StandingNotices),  # status lines that stay true
)  # fmt: skip

TOPIC_SPECS: Final[Mapping[Topic, TopicSpec]] = {s.topic: s for s in _SPECS}
COMMAND_TOPICS: Final = frozenset(s.topic for s in _SPECS if s.command)
STATE_TOPICS: Final = frozenset(s.topic for s in _SPECS if not s.command)
_TOPIC_NAMES: Final = frozenset(str(t) for t in Topic)


# Binary topics: the type each carries, its encoder and its decoder.
_BINARY: Final[Mapping[Topic, tuple[type, Callable[[Any], bytes], Callable[[bytes], object]]]] = {
    Topic.SCAN: (LaserScan, encode_scan, decode_scan),
    Topic.MAP: (OccupancyGrid, encode_map, decode_map),
    Topic.IMAGE: (ImageMsg, encode_image, decode_image),
}


def to_topic(name: Topic | str) -> Topic:
    """The `Topic` called ``name``; raise TopicError for unknown names."""
    try:
        return Topic(str(name))
    except ValueError:
        raise TopicError(f"unknown topic {name!r}; known: {sorted(_TOPIC_NAMES)}") from None


def encode(topic: Topic | str, message: object) -> bytes:
    """Encode ``message`` for ``topic``, checking it is the topic's message type."""
    spec = TOPIC_SPECS[to_topic(topic)]
    if spec.binary:
        kind, encoder, _ = _BINARY[spec.topic]
        if not isinstance(message, kind):
            raise MessageValueError(f"{spec.topic}: cannot encode {type(message).__name__}")
        return encoder(message)
    if type(message) is not spec.message_type or not isinstance(message, JsonMessage):
        raise MessageValueError(
            f"{spec.topic} carries {spec.message_type.__name__}, not {type(message).__name__}"
        )
    return _JSON_ENCODER.encode(message)  # compact; no NaN: fields are validated finite


def decode(topic: Topic | str, payload: bytes) -> object:
    """Decode a payload received on ``topic``; raise TopicDecodeError if it is malformed."""
    spec = TOPIC_SPECS[to_topic(topic)]
    if spec.binary:
        return _BINARY[spec.topic][2](payload)
    message_type: type[JsonMessage] = spec.message_type
    return decode_json(message_type, payload, str(spec.topic))


# --------------------------------------------------------------------------- state snapshot

_SNAPSHOT_PARTS: Final = msgspec.msgpack.Decoder(dict[str, bytes])


def encode_snapshot(parts: Mapping[Topic, bytes]) -> bytes:
    """The ``state`` reply: the preamble, then a MessagePack map of topic name -> payload."""
    body = {str(to_topic(topic)): bytes(data) for topic, data in parts.items()}
    preamble = _PREAMBLE.pack(BINARY_MAGIC, BINARY_VERSION, BinaryKind.SNAPSHOT)
    return preamble + msgspec.msgpack.encode(body)


def decode_snapshot(payload: bytes) -> dict[Topic, bytes]:
    """Split a snapshot into its still-encoded parts (decode each with `decode`)."""
    payload = bytes(payload)
    if len(payload) > MAX_SNAPSHOT_BYTES:
        raise TopicDecodeError(f"snapshot: {len(payload)} bytes > {MAX_SNAPSHOT_BYTES}")
    _check_preamble(payload, BinaryKind.SNAPSHOT, "snapshot")
    try:
        parts = _SNAPSHOT_PARTS.decode(payload[_PREAMBLE.size :])
        return {to_topic(name): data for name, data in parts.items()}
    except (msgspec.DecodeError, TopicError) as exc:  # truncated, trailing bytes, unknown topic
        raise TopicDecodeError(f"snapshot: {exc}") from None
