"""Collision monitor: limit every velocity command by zones on the raw laser scan.

After Nav2's Collision Monitor (nav2_collision_monitor; Macenski et al.), between the velocity
multiplexer's output and the motor driver, so it applies to every source: the planner, the
tablet, the Base Station. Each scan is turned into points in ``base_link`` (people standing in
front of the laser are returns like any other) and checked against zones, polygons in
``base_link`` with an ``action_type``:

* ``stop``: with at least ``min_points`` returns inside, no motion may bring the footprint any
  closer to those returns (Nav2 stops every motion; we let the robot back or turn away, which a
  zone *around* the footprint needs, or it could never leave a wall it stopped at);
* ``slowdown``: both velocities times ``slowdown_ratio``;
* ``limit``: ``|v| <= linear_limit``, ``|omega| <= angular_limit``;
* ``approach``: the time to contact along the commanded arc never falls below
  ``time_before_collision``. With ``t_c`` the time at which the polygon, moved along the arc
  (v, omega) sampled every ``simulation_time_step``, first holds ``min_points`` returns, the
  command is scaled by ``t_c / time_before_collision`` when that is below 1. The scaled command
  follows the same arc, reaching contact after exactly ``time_before_collision``: approaching
  slows down in proportion to the free distance (v = d / T). A turn on the spot is the arc of a
  pure rotation and is scaled the same way.

The most restrictive zone wins. The laser sees 270 degrees, nothing behind the robot: reversing
is capped at ``blind_reverse_speed`` (reported as a ``limit``). Hysteresis: a ``stop``/``slowdown``/``limit`` zone that is
active stays active until fewer than ``min_points`` returns lie within ``hysteresis`` metres of
it, so a return on the edge of a zone does not make the command chatter. Without a scan newer
than ``source_timeout`` the monitor stops the robot and says so (zone ``no_data``), as Nav2
does. The monitor reads no clock: scans and commands come with ``now``. Each scan's returns are
tested against the zones point by point in compiled loops (`zone_members`, `nearest_distance`,
`robot_daemon.jit`).

NOT A CERTIFIED SAFETY SYSTEM (see `robot_daemon.safety`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Annotated, Any, ClassVar, TypeVar

import numpy as np
import numpy.typing as npt
import yaml
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.schema import within
from robot_daemon import jit
from robot_daemon.config import ConfigError
from robot_daemon.safety.arc_geometry import (
    FloatArray,
    PolygonError,
    arc_poses,
    as_polygon,
    distance_to_polygon,
    free_arc_length,
    free_rotation,
    inside_polygon,
    near_arcs,
    point_in_polygon,
    point_to_polygon,
    polygon_box,
    polygon_radius,
)

T = TypeVar("T")

ACTIONS = ("stop", "slowdown", "limit", "approach")
SEVERITY = {"none": 0, "slowdown": 1, "limit": 2, "approach": 3, "stop": 4, "no_data": 5}
MAX_ZONES = 16
ESCAPE_STEP_M = 0.02  # [m] probe along the arc for the stop zone's "not any closer" test
ESCAPE_STEP_RAD = 0.04  # [rad] the same for a turn on the spot
ESCAPE_TOLERANCE = 2e-4  # [m] range noise allowed in that test
DEFAULT_FOOTPRINT = ((0.30, 0.275), (-0.30, 0.275), (-0.30, -0.275), (0.30, -0.275))


class SafetyConfigError(ConfigError):
    """The collision monitor / assisted teleoperation configuration is invalid; says where
    (a robot configuration error: the daemon refuses to start)."""


Points = Annotated[
    tuple[tuple[schema.Finite, schema.Finite], ...],
    Meta(min_length=3, extra={"format": "a list of [x, y] points in base_link [m]"}),
]
"""A polygon in base_link [m]: at least 3 finite vertices (enclosing an area, within 10 m)."""


def check_points(where: str, points: Points) -> None:
    """The rules on a polygon the type cannot say: it encloses an area, within 10 m."""
    try:
        poly = as_polygon(points, f"{where}.points")
    except PolygonError as exc:
        raise SafetyConfigError(str(exc)) from None
    if polygon_radius(poly) > 10.0:
        raise SafetyConfigError(f"{where}.points reach more than 10 m from base_link")


def convert_section(data: object, type_: type[T], root: str, source: str) -> T:
    """``data`` as ``type_`` (checked, rules run); errors say ``source: root.key ...``."""
    return schema.load(data, type_, root, source, SafetyConfigError)


def parse_points(value: object) -> object:
    """Nav2 writes polygons as a string ``"[[x, y], ...]"``: read it as YAML."""
    if not isinstance(value, str):
        return value
    try:
        return yaml.safe_load(value)
    except yaml.YAMLError as exc:
        raise SafetyConfigError(f"'points' is not a list: {exc}") from None


class _Section(schema.Declared, frozen=True):
    ERROR: ClassVar[type[Exception]] = SafetyConfigError


Radius = Annotated[float, within(0.0, 10.0, "m", low_open=True)]  # of a circle zone

# Nav2 keys of a polygon that only its visualisation and topics use: accepted, ignored.
NAV2_DISPLAY_KEYS = ("visualize", "polygon_pub_topic", "polygon_sub_topic", "footprint_topic")


class ZoneConfig(_Section, frozen=True):
    """One zone, named as in Nav2's ``polygons`` list (``points`` in base_link [m])."""

    ROOT: ClassVar[str] = "zone"
    name: str
    action_type: Annotated[str, schema.one_of(*ACTIONS)]
    points: Points
    min_points: Annotated[int, Meta(ge=1, le=1000)] = 3
    slowdown_ratio: Annotated[float, within(0.0, 1.0)] = 0.5
    linear_limit: Annotated[float, within(0.0, 5.0, "m/s")] = 0.3
    angular_limit: Annotated[float, within(0.0, 2 * math.pi, "rad/s")] = 0.5
    time_before_collision: Annotated[float, within(0.0, 10.0, "s", low_open=True)] = 1.2
    simulation_time_step: Annotated[float, within(0.0, 10.0, "s", low_open=True)] = 0.05
    enabled: bool = True

    def check(self) -> None:
        where = f"collision_monitor.{self.name}"
        check_points(where, self.points)
        t, dt = self.time_before_collision, self.simulation_time_step
        if dt > t:
            raise SafetyConfigError(
                f"{where}: simulation_time_step = {dt} s must be <= time_before_collision ({t} s)"
            )
        if t / dt > 200:
            raise SafetyConfigError(
                f"{where}: time_before_collision / simulation_time_step = {t / dt:.0f} steps > 200"
            )

    @property
    def steps(self) -> int:
        return max(1, math.ceil(self.time_before_collision / self.simulation_time_step - 1e-9))

    @classmethod
    def from_mapping(
        cls, name: str, data: Mapping[str, Any], source: str = "collision_monitor"
    ) -> ZoneConfig:
        """A zone of the Nav2 layout: ``type`` polygon (``points``) or circle (``radius``)."""
        where = f"{source}: zone {name!r}"
        if not isinstance(data, Mapping):
            raise SafetyConfigError(f"{where}: must be a mapping of parameters")
        fields = {k: v for k, v in data.items() if k not in NAV2_DISPLAY_KEYS and k != "type"}
        kind = data.get("type", "polygon")
        if kind == "circle":
            radius = schema.checked(
                fields.pop("radius", None), Radius, f"{where}: 'radius'", SafetyConfigError
            )
            a = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
            fields["points"] = [[radius * math.cos(t), radius * math.sin(t)] for t in a]
        elif kind == "polygon":
            if "points" not in fields:
                raise SafetyConfigError(f"{where}: a polygon needs 'points'")
            try:
                fields["points"] = parse_points(fields["points"])
            except SafetyConfigError as exc:
                raise SafetyConfigError(f"{where}: {exc}") from None
        else:
            raise SafetyConfigError(f"{where}: 'type' must be polygon or circle, got {kind!r}")
        return convert_section({"name": name, **fields}, cls, f"collision_monitor.{name}", source)


class CollisionMonitorConfig(_Section, frozen=True):
    """The monitor: footprint (for the reported distance), zones, hysteresis, data timeout."""

    ROOT: ClassVar[str] = "collision_monitor"
    zones: Annotated[tuple[ZoneConfig, ...], Meta(min_length=1, max_length=MAX_ZONES)]
    footprint: Points = DEFAULT_FOOTPRINT
    hysteresis: Annotated[float, within(0.0, 0.5, "m")] = 0.02
    source_timeout: Annotated[float, within(0.0, 10.0, "s", low_open=True)] = 0.5
    # returns farther than this from base_link are ignored
    max_range: Annotated[float, within(0.5, 30.0, "m")] = 4.0
    # the laser sees 270 degrees: nothing behind the robot is seen, so reversing is capped
    blind_reverse_speed: Annotated[float, within(0.0, 5.0, "m/s")] = 0.15
    enabled: bool = True

    def check(self) -> None:
        check_points("collision_monitor.footprint", self.footprint)
        names = [z.name for z in self.zones]
        if len(set(names)) != len(names):
            raise SafetyConfigError(f"collision_monitor: polygon names must be unique, got {names}")

    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], source: str = "<mapping>"
    ) -> CollisionMonitorConfig:
        """The Nav2 layout: ``polygons`` names the zones, each a key of its own."""
        where = f"{source}: collision_monitor"
        if not isinstance(data, Mapping):
            raise SafetyConfigError(f"{where}: must be a mapping")
        if "ros__parameters" in data:  # a Nav2 parameter file pasted as is
            data = data["ros__parameters"]
        names = data.get("polygons")
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise SafetyConfigError(f"{where}: 'polygons' must be a non-empty list of names")
        zones = []
        for name in names:
            if name not in data:
                raise SafetyConfigError(f"{where}: polygon {name!r} is listed but not defined")
            zones.append(ZoneConfig.from_mapping(name, data[name], source))
        fields = {k: v for k, v in data.items() if k != "polygons" and k not in names}
        if "footprint" in fields:
            fields["footprint"] = parse_points(fields["footprint"])
        return convert_section({**fields, "zones": zones}, cls, "collision_monitor", source)


@dataclass(frozen=True)
class MonitorResult:
    """What the monitor let through and why (reported to the station)."""

    linear: float  # [m/s]
    angular: float  # [rad/s]
    zone: str  # none | slowdown | limit | approach | stop | no_data
    zone_name: str = ""
    distance: float = math.inf  # [m] footprint to the nearest return (inf: none in range)
    time_to_contact: float = math.inf  # [s] along the commanded arc (inf: none in the horizon)
    scale: float = 1.0  # output speed / commanded speed


@dataclass
class _Zone:
    config: ZoneConfig
    polygon: FloatArray
    reach: float  # [m] farthest vertex from base_link
    active: bool = False
    members: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    box: FloatArray = field(init=False)  # `polygon_box`, for the kernels

    def __post_init__(self) -> None:
        self.box = polygon_box(self.polygon)


@jit.kernel
def nearest_distance(
    px: FloatArray, py: FloatArray, reach: float, polygon: FloatArray, box: FloatArray
) -> float:
    """Least distance [m] from ``polygon`` (`point_to_polygon`) to the points within
    ``reach`` [m] of base_link; inf with none (a NaN wins, as in numpy's ``min``)."""
    best = math.inf
    for p in range(px.size):
        if math.hypot(px[p], py[p]) <= reach:
            d = point_to_polygon(px[p], py[p], polygon, box)
            if best == best and not best <= d:
                best = d
    return best


@jit.kernel
def zone_members(
    px: FloatArray,
    py: FloatArray,
    reach: float,
    polygon: FloatArray,
    box: FloatArray,
    margin: float,
) -> npt.NDArray[np.bool_]:
    """The points within ``reach`` [m] of base_link that lie inside ``polygon`` or, with
    ``margin`` >= 0, within ``margin`` [m] of it."""
    member = np.zeros(px.size, dtype=np.bool_)
    for p in range(px.size):
        if math.hypot(px[p], py[p]) <= reach:
            member[p] = point_in_polygon(px[p], py[p], polygon, box) or (
                margin >= 0.0 and point_to_polygon(px[p], py[p], polygon, box) <= margin
            )
    return member


class CollisionMonitor:
    """The monitor's state: the newest scan as base_link points and each zone's activity."""

    def __init__(self, config: CollisionMonitorConfig, laser_mount: Pose2D) -> None:
        self.config = config
        self._mount = laser_mount
        self._footprint = np.asarray(config.footprint, dtype=np.float64)
        self._footprint_reach = polygon_radius(self._footprint)
        self._footprint_box = polygon_box(self._footprint)
        self._zones = [
            _Zone(z, np.asarray(z.points, dtype=np.float64), polygon_radius(np.asarray(z.points)))
            for z in config.zones
            if z.enabled
        ]
        self._trig_key: tuple[int, float, float] | None = None
        self._cos = self._sin = np.zeros(0)
        self._px = self._py = np.zeros(0)
        # `_time_to_contact` of this scan's points per (zone, v, w): the stack filters the same
        # command twice or more between two scans (its loop runs faster than the laser).
        self._contacts: dict[tuple[int, float, float, float, float], tuple[float, float]] = {}
        self._stamp = -math.inf
        self._distance = math.inf
        self.scans = 0
        self.last: MonitorResult = MonitorResult(0.0, 0.0, "no_data")

    # -- input -------------------------------------------------------------------------------

    def on_scan(self, scan: LaserScan, now: float) -> None:
        """Take a new scan (received at ``now`` [s]): returns to base_link, zones re-evaluated."""
        n = scan.ranges.size
        key = (n, scan.angle_min, scan.angle_increment)
        if key != self._trig_key:
            a = scan.angles + self._mount.yaw
            self._cos, self._sin, self._trig_key = np.cos(a), np.sin(a), key
        r = scan.ranges
        with np.errstate(invalid="ignore"):
            keep = (r >= scan.range_min) & (r <= min(scan.range_max, self.config.max_range))
        rk = r[keep].astype(np.float64)
        self._px = self._mount.x + rk * self._cos[keep]
        self._py = self._mount.y + rk * self._sin[keep]
        self._contacts = {}
        self._stamp = now
        self.scans += 1
        self._update_zones()

    def _update_zones(self) -> None:
        px, py = self._px, self._py
        h = self.config.hysteresis
        self._distance = nearest_distance(
            px, py, self._footprint_reach + 1.0, self._footprint, self._footprint_box
        )
        for zone in self._zones:
            if zone.config.action_type == "approach":
                continue
            # A zone that is active holds the returns within ``h`` of it too (hysteresis).
            margin = h if zone.active and h > 0 else -1.0
            member = zone_members(px, py, zone.reach + h, zone.polygon, zone.box, margin)
            zone.active = int(np.count_nonzero(member)) >= zone.config.min_points
            zone.members = (
                np.column_stack((px[member], py[member])) if zone.active else np.zeros((0, 2))
            )

    # -- the filter ----------------------------------------------------------------------------

    def update(self, linear: float, angular: float, now: float) -> MonitorResult:
        """The command to send instead of (linear, angular) at ``now`` [s]."""
        if not self.config.enabled:
            self.last = MonitorResult(linear, angular, "none", "disabled", self._distance)
            return self.last
        moving = linear != 0.0 or angular != 0.0
        if now - self._stamp > self.config.source_timeout:
            self.last = MonitorResult(
                0.0, 0.0, "no_data", "laser", math.inf, 0.0, 0.0 if moving else 1.0
            )
            return self.last
        v, w = linear, angular
        zone, zone_name, scale = "none", "", 1.0
        ttc = math.inf

        def note(kind: str, name: str) -> None:
            nonlocal zone, zone_name
            if SEVERITY[kind] > SEVERITY[zone]:
                zone, zone_name = kind, name

        for i, z in enumerate(self._zones):
            cfg = z.config
            if cfg.action_type == "approach":
                if not moving:
                    continue
                key = (i, v, w, math.copysign(1.0, v), math.copysign(1.0, w))  # -0.0 apart
                if key not in self._contacts:
                    self._contacts[key] = self._time_to_contact(z, v, w)
                t_free, t_c = self._contacts[key]
                ttc = min(ttc, t_c)
                ratio = min(1.0, t_free / cfg.time_before_collision)
                if ratio < 1.0:
                    v, w = v * ratio, w * ratio
                    note("approach", cfg.name)
            elif z.active:
                note(cfg.action_type, cfg.name)
                if cfg.action_type == "slowdown":
                    v, w = v * cfg.slowdown_ratio, w * cfg.slowdown_ratio
                elif cfg.action_type == "limit":
                    v = max(-cfg.linear_limit, min(cfg.linear_limit, v))
                    w = max(-cfg.angular_limit, min(cfg.angular_limit, w))
        blind = self.config.blind_reverse_speed
        if v < -blind:  # reversing into what the laser cannot see: capped, on the same arc
            v, w = -blind, w * blind / -v
            note("limit", "blind reverse")
        for z in self._zones:
            stopping = z.active and z.config.action_type == "stop" and (v != 0.0 or w != 0.0)
            if stopping and self._closes_in(z.members, v, w):
                v, w = 0.0, 0.0
        if moving:
            scale = math.hypot(v, w) / math.hypot(linear, angular)
        self.last = MonitorResult(v, w, zone, zone_name, self._distance, ttc, scale)
        return self.last

    def _time_to_contact(self, z: _Zone, v: float, w: float) -> tuple[float, float]:
        """(last free time, first contact time) [s] of the approach polygon along (v, w)."""
        cfg = z.config
        horizon = cfg.time_before_collision
        steps = cfg.steps
        px, py = self._px, self._py
        if v != 0.0:
            cand = near_arcs(px, py, np.array([w / v]), z.reach, v * horizon)
        else:
            cand = np.hypot(px, py) <= z.reach
        px, py = px[cand], py[cand]
        start_inside = inside_polygon(px, py, z.polygon)
        px, py = px[~start_inside], py[~start_inside]
        if px.size < cfg.min_points:
            return math.inf, math.inf
        if v != 0.0:
            length = v * horizon
            s_free = abs(
                float(
                    free_arc_length(
                        px, py, z.polygon, np.array([w / v]), length, steps, cfg.min_points
                    )[0]
                )
            )
            t_free = s_free / abs(v)
        else:
            t_free = abs(
                free_rotation(px, py, z.polygon, w * horizon, steps, cfg.min_points)
            ) / abs(w)
        if t_free >= horizon - 1e-9:
            return math.inf, math.inf
        return t_free, t_free + horizon / steps

    def _closes_in(self, members: FloatArray, v: float, w: float) -> bool:
        """True if a small step along (v, w) brings the footprint closer to any of ``members``."""
        if members.size == 0:
            return False
        px, py = members[:, 0], members[:, 1]
        if v != 0.0:
            s = math.copysign(ESCAPE_STEP_M, v)
            x, y, c, sn = (float(a) for a in arc_poses(np.array(w / v), np.array(s)))
        else:
            t = math.copysign(ESCAPE_STEP_RAD, w)
            x, y, c, sn = 0.0, 0.0, math.cos(t), math.sin(t)
        before = distance_to_polygon(px, py, self._footprint)
        dx, dy = px - x, py - y
        after = distance_to_polygon(c * dx + sn * dy, c * dy - sn * dx, self._footprint)
        return bool(np.any(after < before - ESCAPE_TOLERANCE))

    # -- what the station sees -------------------------------------------------------------------

    @property
    def distance(self) -> float:
        """[m] from the footprint to the nearest return of the newest scan (inf: none near)."""
        return self._distance

    @property
    def points(self) -> tuple[FloatArray, FloatArray]:
        """The newest scan's returns in base_link (x, y) [m] (for assisted teleoperation)."""
        return self._px, self._py

    def fresh(self, now: float) -> bool:
        return now - self._stamp <= self.config.source_timeout
