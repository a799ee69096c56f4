"""Assisted teleoperation: the joystick's command, made safe and kept close to what was meant.

Nav2's AssistedTeleop projects the teleoperation twist forward in steps of
``simulation_time_step`` up to ``projection_time`` and scales it by ``t / projection_time`` when
the footprint collides at step ``t`` (zero at the first step): it only ever slows down, so a
person pushing the joystick slightly askew at a doorway is stopped at the door frame. Here the
same projection is done for a family of arcs around the commanded one and the safest arc
*closest to the intent* is driven, which makes the robot slide along a wall and through a door
when the person pushes roughly the right way:

1. The intent (v_i, omega_i) has curvature ``kappa_i = omega_i / v_i``. Candidate arcs are
   ``kappa = kappa_i + delta`` for ``delta`` in ``[-curvature_span, curvature_span]``.
2. For each arc the free arc length ``s_free`` (the footprint grown by ``margin`` touches no
   return of the newest scan) is found up to ``L = max(|v_i| T, min_lookahead)``, T =
   ``projection_time``, exactly as the collision monitor's ``approach`` zone does.
3. Each arc may be driven at ``v = min(|v_i|, s_free / T)`` (so the time to contact stays >= T),
   ``omega = kappa v``, both within the limits.
4. The cost of an arc is the share of the intended speed it loses, how far it bends away, and
   how soon it is blocked within the lookahead:
   ``J = ((|v_i| - v) / |v_i|)^2 + heading_weight (delta / curvature_span)^2
   + free_weight (1 - s_free / L)^2`` (plus a small penalty for switching side since the last
   command, against dithering left/right). The cheapest arc wins. Head-on into a wall every arc
   is blocked about as soon, so the straight one wins and slows to a stop; at a shallow angle,
   or aiming slightly beside a door, a slightly bent arc stays free and keeps the speed. The
   lookahead ``L`` (at least ``min_lookahead``) sees a door frame before the robot reaches it.

A turn on the spot (|v_i| below ``rotation_threshold``) is projected as a pure rotation and only
scaled. The collision monitor below the multiplexer still checks whatever comes out of here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import within
from robot_daemon.safety.arc_geometry import (
    FloatArray,
    arc_poses,
    closes_in,
    free_path_length,
    free_rotation,
    grow_polygon,
    inside_polygon,
    polygon_radius,
)
from robot_daemon.safety.collision_monitor import (
    DEFAULT_FOOTPRINT,
    ESCAPE_STEP_M,
    ESCAPE_STEP_RAD,
    ESCAPE_TOLERANCE,
    Points,
    SafetyConfigError,
    check_points,
    convert_section,
    parse_points,
)

TELEOP_INPUTS = ("station_vel", "tablet_vel")
DECIMATION_CELL = 0.03  # [m] returns are thinned to one per 3 cm cell for the path search
MAX_STEP = 0.05  # [m] path sampling step


Weight = Annotated[float, within(0.0, 100.0)]


class AssistConfig(schema.Declared, frozen=True):
    """Assisted teleoperation parameters (``assisted_teleop:`` in the safety YAML)."""

    ROOT: ClassVar[str] = "assisted_teleop"
    ERROR: ClassVar[type[Exception]] = SafetyConfigError

    # assisted at start (the station can switch)
    inputs: tuple[Literal["station_vel", "tablet_vel"], ...] = ("tablet_vel",)
    footprint: Points = DEFAULT_FOOTPRINT
    margin: Annotated[float, within(0.0, 0.5, "m")] = 0.06  # footprint growth for the search
    # Nav2 AssistedTeleop's projection_time (= the monitor's)
    projection_time: Annotated[float, within(0.1, 5.0, "s")] = 1.2
    # arcs are searched at least this far (door frames ahead)
    min_lookahead: Annotated[float, within(0.0, 3.0, "m")] = 1.0
    curvature_span: Annotated[float, within(0.0, 10.0, "rad/m")] = 1.2
    curvature_samples: Annotated[int, Meta(ge=1, le=101)] = 13  # odd
    heading_weight: Weight = 0.35
    free_weight: Weight = 0.5
    switch_penalty: Annotated[float, within(0.0, 10.0)] = 0.03
    max_linear: Annotated[float, within(0.0, 5.0, "m/s", low_open=True)] = 1.0
    max_angular: Annotated[float, within(0.0, 2 * math.pi, "rad/s", low_open=True)] = 1.5
    rotation_threshold: Annotated[float, within(0.0, 1.0, "m/s")] = 0.02

    def check(self) -> None:
        check_points("assisted_teleop.footprint", self.footprint)
        if self.curvature_samples % 2 == 0:
            raise SafetyConfigError(
                f"assisted_teleop.curvature_samples must be odd, got {self.curvature_samples}"
            )

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: str = "<mapping>") -> AssistConfig:
        if not isinstance(data, Mapping):
            raise SafetyConfigError(f"{source}: assisted_teleop: must be a mapping")
        fields = dict(data)
        if "footprint" in fields:
            fields["footprint"] = parse_points(fields["footprint"])
        return convert_section(fields, cls, "assisted_teleop", source)


@dataclass(frozen=True)
class AssistResult:
    linear: float  # [m/s]
    angular: float  # [rad/s]
    mode: str  # free | scaled | slid | stopped | idle


def decimate(
    px: FloatArray, py: FloatArray, cell: float = DECIMATION_CELL
) -> tuple[FloatArray, FloatArray]:
    """One return per ``cell``-sized square (the first in scan order)."""
    if px.size == 0:
        return px, py
    kx = np.floor(px / cell).astype(np.int64)
    ky = np.floor(py / cell).astype(np.int64)
    _, idx = np.unique(kx * 1_000_003 + ky, return_index=True)
    return px[idx], py[idx]


class AssistedTeleop:
    """Stateless but for the side of the last slide (see the module docstring)."""

    def __init__(self, config: AssistConfig | None = None) -> None:
        self.config = config = config or AssistConfig()
        self._footprint = np.asarray(config.footprint, dtype=np.float64)
        self._grown = grow_polygon(self._footprint, config.margin)
        self._last_side = 0.0
        offsets = np.linspace(
            -config.curvature_span, config.curvature_span, config.curvature_samples
        )
        self._offsets = offsets[np.argsort(np.abs(offsets), kind="stable")]  # 0 first

    def assist(self, linear: float, angular: float, px: FloatArray, py: FloatArray) -> AssistResult:
        """The command to drive for the intent (linear [m/s], angular [rad/s]) given the newest
        returns (px, py) in base_link [m]."""
        cfg = self.config
        if linear == 0.0 and angular == 0.0:
            return AssistResult(0.0, 0.0, "idle")
        horizon = cfg.projection_time
        lookahead = max(abs(linear) * horizon, cfg.min_lookahead)
        rotating = abs(linear) < cfg.rotation_threshold
        radius = polygon_radius(self._footprint) + cfg.margin
        reach = radius if rotating else radius + lookahead
        near = (np.abs(px) <= reach) & (np.abs(py) <= reach)
        if not rotating:  # moving forward (backward) nothing behind (ahead of) the body counts
            near &= px * math.copysign(1.0, linear) >= -radius
        qx, qy = decimate(px[near], py[near])
        # Returns already within the margin must not get any closer (the monitor's stop zone
        # rule); the others must stay outside the grown footprint along the whole path.
        close = inside_polygon(qx, qy, self._grown)
        cx, cy = qx[close], qy[close]
        qx, qy = qx[~close], qy[~close]
        if rotating:
            return self._rotate(linear, angular, qx, qy, cx, cy)
        sign = math.copysign(1.0, linear)
        kappa_i = angular / linear
        k1 = np.concatenate((kappa_i + self._offsets, kappa_i + self._offsets[1:]))
        k2 = np.concatenate((kappa_i + self._offsets, kappa_i - self._offsets[1:]))  # lane change
        offsets = np.concatenate((self._offsets, self._offsets[1:]))
        steps = max(2, math.ceil(lookahead / MAX_STEP))
        if qx.size:
            s_free = free_path_length(
                qx, qy, self._grown, k1, k2, sign * lookahead / 2, sign * lookahead, steps
            )
        else:
            s_free = np.full(k1.shape, lookahead)
        if cx.size:
            x, y, c, sn = arc_poses(k1, np.full(k1.shape, sign * ESCAPE_STEP_M))
            s_free = np.where(
                closes_in(cx, cy, self._footprint, x, y, c, sn, ESCAPE_TOLERANCE), 0.0, s_free
            )
        speed = np.minimum(abs(linear), s_free / horizon)
        speed = np.minimum(speed, cfg.max_angular / np.maximum(np.abs(k1), 1e-9))
        loss = (abs(linear) - speed) / abs(linear)
        bend = offsets / cfg.curvature_span if cfg.curvature_span > 0 else offsets
        blocked = 1.0 - s_free / lookahead
        cost = loss**2 + cfg.heading_weight * bend**2 + cfg.free_weight * blocked**2
        if self._last_side:
            cost = cost + cfg.switch_penalty * (np.sign(offsets) == -self._last_side)
        best = int(np.argmin(cost))
        v = sign * float(speed[best])
        w = float(k1[best]) * v
        kept = float(speed[best]) / abs(linear)
        if v == 0.0:
            mode = "stopped"
        elif offsets[best] != 0.0:
            mode = "slid"
        else:
            mode = "free" if kept >= 1.0 - 1e-9 else "scaled"
        self._last_side = float(np.sign(offsets[best])) if mode == "slid" else 0.0
        return AssistResult(v, w, mode)

    def _rotate(
        self,
        linear: float,
        angular: float,
        qx: FloatArray,
        qy: FloatArray,
        cx: FloatArray,
        cy: FloatArray,
    ) -> AssistResult:
        horizon = self.config.projection_time
        if angular == 0.0:
            return AssistResult(0.0, 0.0, "idle")
        if cx.size:
            t = math.copysign(ESCAPE_STEP_RAD, angular)
            one = np.ones(1)
            if closes_in(
                cx, cy, self._footprint, 0 * one, 0 * one, math.cos(t) * one,
                math.sin(t) * one, ESCAPE_TOLERANCE,
            )[0]:  # fmt: skip
                return AssistResult(0.0, 0.0, "stopped")
        if qx.size == 0:
            return AssistResult(linear, angular, "free")
        angle = angular * horizon
        steps = max(2, math.ceil(abs(angle) / 0.05))
        free = abs(free_rotation(qx, qy, self._grown, angle, steps))
        ratio = min(1.0, free / abs(angle))
        if ratio >= 1.0:
            return AssistResult(linear, angular, "free")
        mode = "stopped" if ratio == 0.0 else "scaled"
        return AssistResult(linear * ratio, angular * ratio, mode)
