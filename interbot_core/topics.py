"""Zenoh key expressions and payload codecs for the robot <-> Base Station link.

The thesis (§4.2, §5.4, Figs. 5.13-5.14) connects the Base Station to the robot with ROS topics:
``station_vel``, ``tablet_vel`` and the ``pause_nav`` / ``stop`` locks into the twist multiplexer,
``cmd_vel`` out of it, ``scan``, ``map``, ``pose``, ``odom``, ``image``, the goal and the initial
pose. Interbot keeps those names as zenoh keys ``interbot/<robot_id>/<topic>`` and adds what the
thesis did over ad-hoc channels: ``route`` (the whole route, so the robot finishes it when the
station drops), ``route_progress``, ``battery``, ``status``, ``config`` (planner parameters on the
fly), ``mux`` (the active source), ``stop_release`` (the emergency stop latches on the robot),
the liveliness token ``interbot/<robot_id>/alive`` and the query ``interbot/<robot_id>/state``.

Control messages are compact JSON objects, one frozen dataclass each, validated on construction
and on decoding. Scans, maps, images and the state snapshot are binary: a versioned header
(``struct``, little-endian) and a little-endian payload; layouts in docs/topics.md. Every decoder
rejects truncated, oversized, wrong-version or out-of-range payloads with `TopicDecodeError`, and
``decode(encode(m)) == m`` exactly (except the optional millimetre scan encoding, which rounds).

This module is pure: no zenoh, no I/O, no clock. `interbot_link` maps `TopicSpec` onto zenoh QoS.
"""

from __future__ import annotations

import enum
import json
import logging
import math
import re
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Final, Self, TypeVar

import numpy as np

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


# --------------------------------------------------------------------------- field checks


def _fail(cls: type, name: str, why: str) -> MessageValueError:
    return MessageValueError(f"{cls.__name__}.{name} {why}")


def _check_float(obj: object, name: str, lo: float = -math.inf, hi: float = math.inf) -> None:
    value = getattr(obj, name)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(type(obj), name, f"must be a number, got {value!r}")
    if not (math.isfinite(value) and lo <= value <= hi):
        raise _fail(type(obj), name, f"must be finite and in [{lo}, {hi}], got {value!r}")
    object.__setattr__(obj, name, float(value))


def _check_int(obj: object, name: str, lo: int, hi: int) -> None:
    value = getattr(obj, name)
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise _fail(type(obj), name, f"must be an integer in [{lo}, {hi}], got {value!r}")


def _check_bool(obj: object, name: str) -> None:
    if not isinstance(getattr(obj, name), bool):
        raise _fail(type(obj), name, f"must be true or false, got {getattr(obj, name)!r}")


def _check_text(obj: object, name: str, choices: tuple[str, ...] | None = None) -> None:
    value = getattr(obj, name)
    if not isinstance(value, str) or len(value) > MAX_TEXT:
        raise _fail(type(obj), name, f"must be a string of at most {MAX_TEXT} characters")
    if choices is not None and value not in choices:
        raise _fail(type(obj), name, f"must be one of {list(choices)}, got {value!r}")


def _check_stamp(obj: object) -> None:
    _check_float(obj, "stamp", 0.0, 1.0e12)


def _check_xy_yaw(obj: object) -> None:
    _check_float(obj, "x", -MAX_COORD, MAX_COORD)
    _check_float(obj, "y", -MAX_COORD, MAX_COORD)
    _check_float(obj, "yaw", -math.pi, math.pi)


# --------------------------------------------------------------------------- JSON messages


@dataclass(frozen=True)
class JsonMessage:
    """Base of the JSON messages: ``to_dict`` / ``from_dict`` over the dataclass fields."""

    def to_dict(self) -> dict[str, Any]:
        """The JSON object (tuples become lists)."""
        return asdict(self)

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        """Turn a JSON value into the field's Python type (lists into tuples); checks come after."""
        return value

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Self:
        """Build and validate from a decoded JSON object; raise MessageValueError on any problem."""
        if not isinstance(data, Mapping):
            raise MessageValueError(f"{cls.__name__} must be a JSON object")
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise MessageValueError(f"{cls.__name__} has unknown fields {sorted(unknown)}")
        kwargs = {name: cls._convert(name, value) for name, value in data.items()}
        try:
            return cls(**kwargs)
        except TypeError as exc:  # a required field is missing
            raise MessageValueError(f"{cls.__name__}: {exc}") from exc


@dataclass(frozen=True)
class Twist(JsonMessage):
    """A velocity command or report: ``linear`` [m/s] forward, ``angular`` [rad/s] CCW."""

    linear: float
    angular: float
    stamp: float = 0.0  # [s] sender's clock

    def __post_init__(self) -> None:
        _check_float(self, "linear", -MAX_LINEAR, MAX_LINEAR)
        _check_float(self, "angular", -MAX_ANGULAR, MAX_ANGULAR)
        _check_stamp(self)


@dataclass(frozen=True)
class Lock(JsonMessage):
    """A multiplexer lock value (``pause_nav``, ``stop``): engaged masks lower priorities."""

    engaged: bool
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_bool(self, "engaged")
        _check_stamp(self)


@dataclass(frozen=True)
class StopRelease(JsonMessage):
    """Release the latched emergency stop; ``operator`` names who released it (for the log)."""

    operator: str = ""
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_text(self, "operator")
        _check_stamp(self)


POSE_STATES: Final = ("unset", "ok", "degraded", "lost", "searching")
MAX_POSE_VARIANCE: Final = 1.0e6  # [m², rad²] bound on a covariance entry


@dataclass(frozen=True)
class PoseMsg(JsonMessage):
    """The localiser's pose in the ``map`` frame.

    ``state``: unset (no initial pose), ok, degraded (tracking, but uncertain or the last
    scans disagree with the map: drive slowly), lost, searching (global localisation).
    ``covariance``: 3x3 of (x [m], y [m], yaw [rad]), row-major (ROS's
    ``PoseWithCovariance`` restricted to the plane), or empty when not reported.
    """

    x: float
    y: float
    yaw: float
    stamp: float = 0.0
    state: str = "ok"
    confidence: float = 1.0  # [0, 1]
    covariance: tuple[float, ...] = ()

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        return tuple(value) if name == "covariance" and isinstance(value, list) else value

    def __post_init__(self) -> None:
        _check_xy_yaw(self)
        _check_stamp(self)
        _check_text(self, "state", POSE_STATES)
        _check_float(self, "confidence", 0.0, 1.0)
        cov = self.covariance
        if not isinstance(cov, tuple) or len(cov) not in (0, 9):
            raise _fail(type(self), "covariance", "must be a list of 0 or 9 numbers")
        for i, v in enumerate(cov):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise _fail(type(self), "covariance", "must hold finite numbers")
            if abs(v) > MAX_POSE_VARIANCE or (i in (0, 4, 8) and v < 0.0):
                raise _fail(
                    type(self), "covariance", "entries must be within ±1e6, the diagonal >= 0"
                )

    @property
    def sigmas(self) -> tuple[float, float, float] | None:
        """Standard deviations of x [m], y [m], yaw [rad]; None when no covariance."""
        if not self.covariance:
            return None
        c = self.covariance
        return (math.sqrt(c[0]), math.sqrt(c[4]), math.sqrt(c[8]))


@dataclass(frozen=True)
class Odom(JsonMessage):
    """Wheel odometry in the ``odom`` frame and the measured velocities."""

    x: float
    y: float
    yaw: float
    linear: float = 0.0  # [m/s]
    angular: float = 0.0  # [rad/s]
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_xy_yaw(self)
        _check_float(self, "linear", -MAX_LINEAR, MAX_LINEAR)
        _check_float(self, "angular", -MAX_ANGULAR, MAX_ANGULAR)
        _check_stamp(self)


@dataclass(frozen=True)
class RouteMsg(JsonMessage):
    """A whole route: waypoints ``(x, y, yaw)`` in the ``map`` frame, the last one the goal.

    ``node_ids`` are the topological nodes of the waypoints (empty, or one per waypoint);
    ``approach_tolerance`` [m] is how close an intermediate waypoint must be reached,
    ``goal_tolerance`` [m] and ``yaw_tolerance`` [rad] apply to the final one.
    """

    route_id: int
    waypoints: tuple[tuple[float, float, float], ...]
    node_ids: tuple[int, ...] = ()
    approach_tolerance: float = 0.7
    goal_tolerance: float = 0.25
    yaw_tolerance: float = 0.25

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        if name == "waypoints" and isinstance(value, list):
            return tuple(tuple(w) if isinstance(w, list) else w for w in value)
        if name == "node_ids" and isinstance(value, list):
            return tuple(value)
        return value

    def __post_init__(self) -> None:
        _check_int(self, "route_id", 0, ROUTE_ID_MAX)
        wps = self.waypoints
        if not isinstance(wps, tuple) or not 1 <= len(wps) <= MAX_LIST_LENGTH:
            raise _fail(type(self), "waypoints", f"must hold 1..{MAX_LIST_LENGTH} waypoints")
        for i, w in enumerate(wps):
            if not _is_waypoint(w):
                raise _fail(
                    type(self),
                    f"waypoints[{i}]",
                    f"must be [x, y, yaw] with |x|, |y| <= {MAX_COORD} m and |yaw| <= pi, got {w!r}",
                )
        object.__setattr__(self, "waypoints", tuple(tuple(float(v) for v in w) for w in wps))
        ids = self.node_ids
        if not isinstance(ids, tuple) or len(ids) not in (0, len(wps)):
            raise _fail(type(self), "node_ids", "must be empty or hold one id per waypoint")
        for i, n in enumerate(ids):
            if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n < 2**31:
                raise _fail(type(self), f"node_ids[{i}]", f"must be an integer >= 0, got {n!r}")
        _check_float(self, "approach_tolerance", 1e-3, 100.0)
        _check_float(self, "goal_tolerance", 1e-3, 100.0)
        _check_float(self, "yaw_tolerance", 1e-3, math.pi)


def _is_waypoint(w: object) -> bool:
    if not isinstance(w, tuple) or len(w) != 3:
        return False
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in w):
        return False
    x, y, yaw = (float(v) for v in w)
    finite = all(math.isfinite(v) for v in (x, y, yaw))
    return finite and abs(x) <= MAX_COORD and abs(y) <= MAX_COORD and abs(yaw) <= math.pi


@dataclass(frozen=True)
class RouteCancel(JsonMessage):
    """Drop route ``route_id`` (or whatever route is in progress when it is None)."""

    route_id: int | None = None
    reason: str = ""
    stamp: float = 0.0

    def __post_init__(self) -> None:
        if self.route_id is not None:
            _check_int(self, "route_id", 0, ROUTE_ID_MAX)
        _check_text(self, "reason")
        _check_stamp(self)


ROUTE_STATES: Final = ("idle", "active", "paused", "succeeded", "aborted", "canceled")


@dataclass(frozen=True)
class RouteProgress(JsonMessage):
    """Progress on route ``route_id``: heading for waypoint ``index``; why it ended, if it did."""

    route_id: int
    index: int
    reached_final: bool = False
    state: str = "active"
    reason: str = ""
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_int(self, "route_id", 0, ROUTE_ID_MAX)
        _check_int(self, "index", 0, MAX_LIST_LENGTH)
        _check_bool(self, "reached_final")
        _check_text(self, "state", ROUTE_STATES)
        _check_text(self, "reason")
        _check_stamp(self)


@dataclass(frozen=True)
class GoalMsg(JsonMessage):
    """Go to a map point, or to topological node ``node_id`` (then x, y, yaw are its pose)."""

    x: float
    y: float
    yaw: float
    node_id: int | None = None
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_xy_yaw(self)
        if self.node_id is not None:
            _check_int(self, "node_id", 0, 2**31 - 1)
        _check_stamp(self)


@dataclass(frozen=True)
class InitialPose(JsonMessage):
    """Set the localiser's pose (RViz's "2D Pose Estimate", the tablet's "Help me!").

    ``verify``: the pose is only a hint (a room picked by a person): the robot searches around
    it and applies it only if the laser confirms it."""

    x: float
    y: float
    yaw: float
    stamp: float = 0.0
    verify: bool = False

    def __post_init__(self) -> None:
        _check_xy_yaw(self)
        _check_stamp(self)
        _check_bool(self, "verify")


@dataclass(frozen=True)
class Relocalise(JsonMessage):
    """Ask the robot to find itself on the whole map (global localisation, issue 16)."""

    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_stamp(self)


@dataclass(frozen=True)
class Battery(JsonMessage):
    """BMS reading: ``voltage`` [V], ``current`` [A] (positive = discharging), ``soc`` [0, 1]."""

    voltage: float
    current: float = 0.0
    soc: float = 1.0
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_float(self, "voltage", 0.0, 1000.0)
        _check_float(self, "current", -1000.0, 1000.0)
        _check_float(self, "soc", 0.0, 1.0)
        _check_stamp(self)


STATUS_LEVELS: Final = ("info", "warning", "error")


@dataclass(frozen=True)
class Status(JsonMessage):
    """What the Base Station UI shows (thesis §5.2.1): the task, a message, distance to go."""

    level: str
    text: str
    task: str = ""
    distance_to_goal: float | None = None  # [m]
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_text(self, "level", STATUS_LEVELS)
        _check_text(self, "text")
        _check_text(self, "task")
        if self.distance_to_goal is not None:
            _check_float(self, "distance_to_goal", 0.0, 1.0e7)
        _check_stamp(self)


_PARAM_NAME = re.compile(r"[a-z_][a-z0-9_.]{0,63}")


@dataclass(frozen=True)
class ConfigMsg(JsonMessage):
    """Planner parameters changed on the fly: ``{name: value}``, values bool, int, float or str."""

    params: dict[str, bool | int | float | str]

    def __post_init__(self) -> None:
        params = self.params
        if not isinstance(params, dict) or not 1 <= len(params) <= MAX_LIST_LENGTH:
            raise _fail(type(self), "params", f"must be an object of 1..{MAX_LIST_LENGTH} entries")
        for name, value in params.items():
            if not isinstance(name, str) or _PARAM_NAME.fullmatch(name) is None:
                raise _fail(type(self), "params", f"name {name!r} must match [a-z_][a-z0-9_.]*")
            if isinstance(value, float) and not math.isfinite(value):
                raise _fail(type(self), f"params[{name!r}]", "must be finite")
            if not isinstance(value, bool | int | float | str) or (
                isinstance(value, str) and len(value) > MAX_TEXT
            ):
                raise _fail(type(self), f"params[{name!r}]", f"has unsupported value {value!r}")
        object.__setattr__(self, "params", dict(params))


@dataclass(frozen=True)
class MuxMsg(JsonMessage):
    """The velocity multiplexer's output: winning ``source`` (None: explicit zero) and why."""

    source: str | None
    reason: str = ""
    active_locks: tuple[str, ...] = ()
    linear: float = 0.0
    angular: float = 0.0
    stamp: float = 0.0

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        return tuple(value) if name == "active_locks" and isinstance(value, list) else value

    def __post_init__(self) -> None:
        if self.source is not None:
            _check_text(self, "source")
        _check_text(self, "reason")
        locks = self.active_locks
        if not isinstance(locks, tuple) or len(locks) > MAX_LIST_LENGTH:
            raise _fail(type(self), "active_locks", "must be a list of lock names")
        if not all(isinstance(n, str) and len(n) <= MAX_TEXT for n in locks):
            raise _fail(type(self), "active_locks", "must hold strings")
        _check_float(self, "linear", -MAX_LINEAR, MAX_LINEAR)
        _check_float(self, "angular", -MAX_ANGULAR, MAX_ANGULAR)
        _check_stamp(self)


@dataclass(frozen=True)
class PlanMsg(JsonMessage):
    """The navigator's global path in the ``map`` frame, as planned (empty: no path).

    ``route_id`` is the route it serves (0: none); ``points`` are ``(x, y)`` [m], thinned by the
    robot to at most `MAX_LIST_LENGTH` so the station draws what the robot will drive, not
    straight lines between the route's waypoints.
    """

    route_id: int
    points: tuple[tuple[float, float], ...]
    stamp: float = 0.0

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        if name == "points" and isinstance(value, list):
            return tuple(tuple(p) if isinstance(p, list) else p for p in value)
        return value

    def __post_init__(self) -> None:
        _check_int(self, "route_id", 0, 2**63)
        pts = self.points
        if not isinstance(pts, tuple) or len(pts) > MAX_LIST_LENGTH:
            raise _fail(type(self), "points", f"must hold at most {MAX_LIST_LENGTH} points")
        for i, p in enumerate(pts):
            if not (
                isinstance(p, tuple)
                and len(p) == 2
                and all(
                    not isinstance(v, bool)
                    and isinstance(v, int | float)
                    and math.isfinite(v)
                    and abs(v) <= MAX_COORD
                    for v in p
                )
            ):
                raise _fail(type(self), f"points[{i}]", f"must be [x, y] in the map, got {p!r}")
        object.__setattr__(self, "points", tuple((float(x), float(y)) for x, y in pts))
        _check_stamp(self)


TELEOP_INPUT_TOPICS: Final = ("station_vel", "tablet_vel")
SAFETY_ZONES: Final = ("none", "slowdown", "limit", "approach", "stop", "no_data")
MAX_SAFETY_DISTANCE: Final = 1000.0  # [m] "nothing near" is sent as this (JSON has no inf)


@dataclass(frozen=True)
class AssistMsg(JsonMessage):
    """Assisted teleoperation on/off for one joystick input (``station_vel`` / ``tablet_vel``)."""

    input: str
    enabled: bool
    stamp: float = 0.0

    def __post_init__(self) -> None:
        _check_text(self, "input", TELEOP_INPUT_TOPICS)
        _check_bool(self, "enabled")
        _check_stamp(self)


@dataclass(frozen=True)
class SafetyMsg(JsonMessage):
    """The collision monitor's state for the person driving (issue 17; NOT a certified safety
    function): the most restrictive active ``zone`` and its name, the distance [m] from the
    footprint to the nearest laser return and the time to contact [s] along the commanded arc
    (``MAX_SAFETY_DISTANCE`` when none), the share of the commanded speed let through, the
    inputs with assisted teleoperation on, and what the assistance did last."""

    zone: str
    zone_name: str = ""
    distance: float = MAX_SAFETY_DISTANCE
    time_to_contact: float = MAX_SAFETY_DISTANCE
    scale: float = 1.0
    assisted: tuple[str, ...] = ()
    assist_mode: str = "idle"
    stamp: float = 0.0

    @classmethod
    def _convert(cls, name: str, value: Any) -> Any:
        return tuple(value) if name == "assisted" and isinstance(value, list) else value

    def __post_init__(self) -> None:
        _check_text(self, "zone", SAFETY_ZONES)
        _check_text(self, "zone_name")
        _check_float(self, "distance", 0.0, MAX_SAFETY_DISTANCE)
        _check_float(self, "time_to_contact", 0.0, MAX_SAFETY_DISTANCE)
        _check_float(self, "scale", 0.0, 1.0)
        assisted = self.assisted
        if not isinstance(assisted, tuple) or not all(a in TELEOP_INPUT_TOPICS for a in assisted):
            raise _fail(type(self), "assisted", f"must list some of {list(TELEOP_INPUT_TOPICS)}")
        _check_text(self, "assist_mode", ("idle", "free", "scaled", "slid", "stopped"))
        _check_stamp(self)


def encode_json(message: JsonMessage) -> bytes:
    """Compact UTF-8 JSON of a message (no NaN: fields are validated finite)."""
    return json.dumps(message.to_dict(), separators=(",", ":"), allow_nan=False).encode()


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


def _pairs_without_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """An object whose keys are unique (``{"linear":0.1,"linear":4.9}`` is refused, as on TCP)."""
    obj: dict[str, Any] = {}
    for name, value in pairs:
        if name in obj:
            raise ValueError(f"duplicate key {name!r}")
        obj[name] = value
    return obj


M = TypeVar("M", bound=JsonMessage)


def decode_json(cls: type[M], payload: bytes, topic: str = "") -> M:
    """Parse and validate ``payload`` as ``cls``; raise TopicDecodeError naming the topic."""
    where = topic or cls.__name__
    if len(payload) > MAX_JSON_BYTES:
        raise TopicDecodeError(f"{where}: payload of {len(payload)} bytes > {MAX_JSON_BYTES}")
    try:
        data = json.loads(
            bytes(payload).decode("utf-8"),
            parse_constant=_reject_constant,
            object_pairs_hook=_pairs_without_duplicates,
        )
        return cls.from_dict(data)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise TopicDecodeError(f"{where}: {exc}") from exc


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


@dataclass(frozen=True)
class ImageMsg:
    """A camera frame: JPEG bytes of a ``width`` x ``height`` image taken at ``stamp`` [s]."""

    stamp: float
    width: int
    height: int
    jpeg: bytes = field(repr=False)

    def __post_init__(self) -> None:
        _check_stamp(self)
        _check_int(self, "width", 1, 65535)
        _check_int(self, "height", 1, 65535)
        if not isinstance(self.jpeg, bytes) or not self.jpeg.startswith(JPEG_SOI):
            raise MessageValueError("ImageMsg.jpeg must be JPEG bytes (starting FF D8)")
        if len(self.jpeg) > MAX_IMAGE_BYTES:
            raise MessageValueError(f"ImageMsg.jpeg is {len(self.jpeg)} bytes > {MAX_IMAGE_BYTES}")


_IMAGE = struct.Struct("<2sBBdHHBI")  # preamble, stamp, width, height, format (1 JPEG), length
_IMAGE_JPEG = 1


def encode_image(image: ImageMsg) -> bytes:
    """Binary image: header then the JPEG bytes."""
    head = _IMAGE.pack(
        BINARY_MAGIC,
        BINARY_VERSION,
        BinaryKind.IMAGE,
        image.stamp,
        image.width,
        image.height,
        _IMAGE_JPEG,
        len(image.jpeg),
    )
    return head + image.jpeg


def decode_image(payload: bytes) -> ImageMsg:
    """Inverse of `encode_image`."""
    payload = bytes(payload)
    _check_preamble(payload, BinaryKind.IMAGE, "image")
    if len(payload) < _IMAGE.size:
        raise TopicDecodeError(f"image: truncated header ({len(payload)} < {_IMAGE.size} bytes)")
    _, _, _, stamp, width, height, fmt, length = _IMAGE.unpack_from(payload)
    if fmt != _IMAGE_JPEG:
        raise TopicDecodeError(f"image: unknown format {fmt} (1 = JPEG)")
    if length > MAX_IMAGE_BYTES or len(payload) != _IMAGE.size + length:
        raise TopicDecodeError(f"image: {len(payload)} bytes, header says {_IMAGE.size + length}")
    try:
        return ImageMsg(stamp, width, height, payload[_IMAGE.size :])
    except MessageValueError as exc:
        raise TopicDecodeError(f"image: {exc}") from exc


# --------------------------------------------------------------------------- topic table


@dataclass(frozen=True)
class TopicSpec:
    """How a topic travels: direction, encoding, nominal rate and delivery class.

    ``must_arrive`` topics are sent with congestion control BLOCK (never dropped in a full
    queue); ``latest_only`` topics are consumed newest-value-first (a ring of one).
    """

    topic: Topic
    command: bool  # True: station -> robot; False: robot -> station
    binary: bool
    must_arrive: bool
    latest_only: bool
    rate_hz: float | None  # nominal; None = on change
    message_type: type
    description: str


_SPECS: Final = (
    TopicSpec(Topic.STATION_VEL, True, False, False, True, 20.0, Twist, "Base Station teleoperation (mux priority 100)"),
    TopicSpec(Topic.TABLET_VEL, True, False, False, True, 20.0, Twist, "tablet joystick via the station (mux priority 50)"),
    TopicSpec(Topic.PAUSE_NAV, True, False, True, False, None, Lock, "pause/resume navigation lock (priority 25)"),
    TopicSpec(Topic.STOP, True, False, True, False, None, Lock, "emergency stop lock (priority 255, latches)"),
    TopicSpec(Topic.STOP_RELEASE, True, False, True, False, None, StopRelease, "release the latched emergency stop"),
    TopicSpec(Topic.ROUTE, True, False, True, False, None, RouteMsg, "whole route to follow"),
    TopicSpec(Topic.ROUTE_CANCEL, True, False, True, False, None, RouteCancel, "drop the route in progress"),
    TopicSpec(Topic.GOAL, True, False, True, False, None, GoalMsg, "single goal; the robot plans the route"),
    TopicSpec(Topic.INITIAL_POSE, True, False, True, False, None, InitialPose, "set the localiser's pose"),
    TopicSpec(Topic.RELOCALISE, True, False, True, False, None, Relocalise, "find the robot on the whole map"),
    TopicSpec(Topic.CONFIG, True, False, True, False, None, ConfigMsg, "planner parameters on the fly"),
    TopicSpec(Topic.TELEOP_ASSIST, True, False, True, False, None, AssistMsg, "assisted teleoperation on/off per joystick input"),
    TopicSpec(Topic.CMD_VEL, False, False, False, True, 20.0, Twist, "mux output sent to the motors"),
    TopicSpec(Topic.POSE, False, False, False, True, 40.0, PoseMsg, "localised pose in the map frame"),
    TopicSpec(Topic.ODOM, False, False, False, True, 20.0, Odom, "wheel odometry"),
    TopicSpec(Topic.SCAN, False, True, False, True, 40.0, LaserScan, "laser scan (binary)"),
    TopicSpec(Topic.MAP, False, True, False, False, 0.2, OccupancyGrid, "occupancy grid (binary, zlib)"),
    TopicSpec(Topic.ROUTE_PROGRESS, False, False, True, False, None, RouteProgress, "route/goal status"),
    TopicSpec(Topic.IMAGE, False, True, False, True, 10.0, ImageMsg, "camera frame (binary JPEG)"),
    TopicSpec(Topic.BATTERY, False, False, False, True, 1.0, Battery, "battery state"),
    TopicSpec(Topic.STATUS, False, False, True, False, None, Status, "status text for the UI"),
    TopicSpec(Topic.MUX, False, False, False, True, 5.0, MuxMsg, "active velocity source"),
    TopicSpec(Topic.PLAN, False, False, False, True, None, PlanMsg, "the navigator's global path"),
    TopicSpec(Topic.SAFETY, False, False, False, True, 10.0, SafetyMsg, "collision monitor zone, distance, assistance"),
)  # fmt: skip

TOPIC_SPECS: Final[Mapping[Topic, TopicSpec]] = {s.topic: s for s in _SPECS}
COMMAND_TOPICS: Final = frozenset(s.topic for s in _SPECS if s.command)
STATE_TOPICS: Final = frozenset(s.topic for s in _SPECS if not s.command)
_TOPIC_NAMES: Final = frozenset(str(t) for t in Topic)


def _encode_binary(topic: Topic, message: object) -> bytes:
    if topic is Topic.SCAN and isinstance(message, LaserScan):
        return encode_scan(message)
    if topic is Topic.MAP and isinstance(message, OccupancyGrid):
        return encode_map(message)
    if topic is Topic.IMAGE and isinstance(message, ImageMsg):
        return encode_image(message)
    raise MessageValueError(f"{topic}: cannot encode {type(message).__name__}")


_BINARY_DECODERS: Final[Mapping[Topic, Callable[[bytes], object]]] = {
    Topic.SCAN: decode_scan,
    Topic.MAP: decode_map,
    Topic.IMAGE: decode_image,
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
        return _encode_binary(spec.topic, message)
    if type(message) is not spec.message_type or not isinstance(message, JsonMessage):
        raise MessageValueError(
            f"{spec.topic} carries {spec.message_type.__name__}, not {type(message).__name__}"
        )
    return encode_json(message)


def decode(topic: Topic | str, payload: bytes) -> object:
    """Decode a payload received on ``topic``; raise TopicDecodeError if it is malformed."""
    spec = TOPIC_SPECS[to_topic(topic)]
    if spec.binary:
        return _BINARY_DECODERS[spec.topic](payload)
    message_type: type[JsonMessage] = spec.message_type
    return decode_json(message_type, payload, str(spec.topic))


# --------------------------------------------------------------------------- state snapshot

_SNAPSHOT = struct.Struct("<2sBBH")  # preamble, section count
_SECTION_NAME = struct.Struct("<B")
_SECTION_LEN = struct.Struct("<I")


def encode_snapshot(parts: Mapping[Topic, bytes]) -> bytes:
    """Concatenate encoded state payloads: header, then per part name length u8, name, u32, data."""
    chunks = [_SNAPSHOT.pack(BINARY_MAGIC, BINARY_VERSION, BinaryKind.SNAPSHOT, len(parts))]
    for topic, data in parts.items():
        name = str(to_topic(topic)).encode("ascii")
        chunks += [_SECTION_NAME.pack(len(name)), name, _SECTION_LEN.pack(len(data)), bytes(data)]
    return b"".join(chunks)


def decode_snapshot(payload: bytes) -> dict[Topic, bytes]:
    """Split a snapshot into its still-encoded parts (decode each with `decode`)."""
    payload = bytes(payload)
    if len(payload) > MAX_SNAPSHOT_BYTES:
        raise TopicDecodeError(f"snapshot: {len(payload)} bytes > {MAX_SNAPSHOT_BYTES}")
    _check_preamble(payload, BinaryKind.SNAPSHOT, "snapshot")
    if len(payload) < _SNAPSHOT.size:
        raise TopicDecodeError("snapshot: truncated header")
    count = _SNAPSHOT.unpack_from(payload)[3]
    pos = _SNAPSHOT.size
    parts: dict[Topic, bytes] = {}
    for i in range(count):
        if pos + 1 > len(payload):
            raise TopicDecodeError(f"snapshot: truncated at part {i}")
        (name_len,) = _SECTION_NAME.unpack_from(payload, pos)
        pos += 1
        name_end = pos + name_len
        if name_end + _SECTION_LEN.size > len(payload):
            raise TopicDecodeError(f"snapshot: truncated at part {i}")
        try:
            topic = to_topic(payload[pos:name_end].decode("ascii"))
        except (UnicodeDecodeError, TopicError) as exc:
            raise TopicDecodeError(f"snapshot: part {i}: {exc}") from exc
        (length,) = _SECTION_LEN.unpack_from(payload, name_end)
        pos = name_end + _SECTION_LEN.size
        if pos + length > len(payload):
            raise TopicDecodeError(f"snapshot: part {i} ({topic}) truncated")
        if topic in parts:
            raise TopicDecodeError(f"snapshot: part {topic} appears twice")
        parts[topic] = payload[pos : pos + length]
        pos += length
    if pos != len(payload):
        raise TopicDecodeError(f"snapshot: {len(payload) - pos} trailing bytes")
    return parts
