"""Navigation parameters: one frozen :class:`PlannerConfig`, declared with its ranges (msgspec).

Defaults follow the thesis where it gives values (Table 6.3: maximum speeds 0.25 m/s and
1 rad/s, minimum linear speed 0, goal tolerances 0.5 m and 0.1 rad; robot footprint 0.60 x
0.55 m) and Nav2 / DWB elsewhere (inflation, progress checker, recoveries; see
shared/FIELD_NOTES.md "Navigation reference values"). Change values at run time with
``PlannerConfig.replace(**changes)`` (or ``Navigator.reconfigure``), which validates again.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import within


class PlannerConfigError(ValueError):
    """A navigation parameter is unknown or out of range; the message names it."""


MAX_ROLLOUT_STEPS = 20_000
"""Most integration steps of one local-planner cycle, ``v_samples * w_samples * sim_time/sim_dt``
(the default is 3 465, about 10 ms here; the bound keeps a cycle well under 0.1 s)."""
MAX_FIELD_CELLS = 1_000_000
"""Most cells of the robot-centred obstacle grid (about 8 MB of float64)."""


# Closed, physically sensible bounds on every number (issue 11): no value in them can exhaust
# memory or freeze the control loop (with `MAX_ROLLOUT_STEPS` and `MAX_FIELD_CELLS` below), from a
# file or a ``config`` message alike.
Speed = Annotated[float, within(0.05, 1.0, "m/s")]
Metres = Annotated[float, within(0.05, 5.0, "m")]
Range = Annotated[float, within(0.5, 30.0, "m")]
Angle = Annotated[float, within(0.01, math.pi, "rad")]
Timeout = Annotated[float, within(1.0, 300.0, "s")]


class PlannerConfig(schema.Declared, frozen=True):
    """Everything the navigator, its planners and its costmap need (SI units).

    Each field's type carries its allowed range; a value outside it, of the wrong type or NaN
    raises `PlannerConfigError` naming the field, the value and the range."""

    ROOT: ClassVar[str] = "PlannerConfig"
    ERROR: ClassVar[type[Exception]] = PlannerConfigError

    # Velocity limits, thesis Table 6.3 (rotational minimum -1 rad/s = -max_angular_speed).
    max_linear_speed: Speed = 0.25
    # 0: the controller never reverses (recoveries may)
    min_linear_speed: Annotated[float, within(-0.5, 1.0, "m/s")] = 0.0
    max_angular_speed: Annotated[float, within(0.1, 3.0, "rad/s")] = 1.0
    linear_acceleration: Annotated[float, within(0.05, 3.0, "m/s^2")] = 0.5
    angular_acceleration: Annotated[float, within(0.1, 10.0, "rad/s^2")] = 2.0
    # Goal checking, thesis Table 6.3; approach tolerance of intermediate goals (§5.3.6).
    goal_xy_tolerance: Annotated[float, within(0.01, 2.0, "m")] = 0.5
    goal_yaw_tolerance: Angle = 0.1
    approach_tolerance: Metres = 0.7  # Nav2 drops via-points within 0.7 m
    # Robot: rectangular footprint, centred on the base_link origin.
    robot_length: Annotated[float, within(0.1, 2.0, "m")] = 0.60  # along x
    robot_width: Annotated[float, within(0.1, 2.0, "m")] = 0.55  # along y
    laser_x_offset: Annotated[float, within(-1.0, 1.0, "m")] = 0.0  # laser ahead of base_link
    # Costmap (Nav2 inflation layer and obstacle layer).
    inflation_radius: Annotated[float, within(0.05, 3.0, "m")] = 0.6
    cost_scaling_factor: Annotated[float, within(0.1, 50.0, "1/m")] = 5.0
    # how long a laser mark lives without a new hit
    obstacle_persistence: Annotated[float, within(0.01, 60.0, "s")] = 2.0
    obstacle_max_range: Range = 4.0
    raytrace_max_range: Range = 5.0
    # Nav2's planner ``allow_unknown`` (its default is True) with the static layer's
    # ``track_unknown_space``: unknown cells are then not obstacles (not inflated) but cost
    # UNKNOWN_COST, the most a traversable cell costs, so paths cross them only where nothing
    # known will do. False: unknown is lethal.
    allow_unknown: bool = False
    # Global planner.
    planning_resolution: Annotated[float, within(0.025, 0.5, "m")] = 0.1
    cost_weight: Annotated[float, within(0.0, 1e4)] = 100.0
    path_spacing: Annotated[float, within(0.05, 2.0, "m")] = 0.25
    replan_period: Annotated[float, within(0.1, 60.0, "s")] = 1.0
    # Local planner (dynamic window approach).
    sim_time: Annotated[float, within(0.3, 5.0, "s")] = 1.5  # trajectory horizon
    sim_dt: Annotated[float, within(0.02, 0.5, "s")] = 0.1  # integration step of the rollouts
    v_samples: Annotated[int, Meta(ge=2, le=41)] = 11
    w_samples: Annotated[int, Meta(ge=3, le=61)] = 21
    lookahead: Annotated[float, within(0.2, 5.0, "m")] = 1.0  # carrot distance along the path
    local_grid_resolution: Annotated[float, within(0.02, 0.2, "m")] = 0.05
    # below this footprint clearance the speed limit drops
    slowdown_clearance: Annotated[float, within(0.0, 2.0, "m")] = 0.3
    # speed limit at zero clearance, fraction of the maximum
    slowdown_min_fraction: Annotated[float, within(0.05, 1.0)] = 0.4
    approach_slowdown_distance: Metres = 1.0  # final approach: limit = max * d / this
    # beyond this path-heading error, turn in place
    rotate_to_heading_angle: Annotated[float, within(0.1, math.pi, "rad")] = 1.2
    yaw_gain: Annotated[float, within(0.1, 10.0, "1/s")] = 1.5  # P gain of the final rotation
    # rotation never slower than this until aligned
    min_rotation_speed: Annotated[float, within(0.0, 1.0, "rad/s")] = 0.1
    # Progress checker and recoveries (Nav2 behaviour tree defaults).
    progress_distance: Metres = 0.5
    progress_timeout: Timeout = 10.0
    # recoveries without progress -> "blocked"
    blocked_timeout: Annotated[float, within(1.0, 3600.0, "s")] = 30.0
    spin_angle: Annotated[float, within(0.0, 2 * math.pi, "rad")] = math.pi / 2
    backup_distance: Annotated[float, within(0.0, 1.0, "m")] = 0.3
    backup_speed: Annotated[float, within(0.02, 0.5, "m/s")] = 0.1
    wait_duration: Annotated[float, within(0.0, 120.0, "s")] = 5.0

    def check(self) -> None:
        """Rules across fields: speeds ordered, inflation covers the robot, a cycle stays short."""
        if self.min_linear_speed > self.max_linear_speed:
            raise PlannerConfigError(
                f"PlannerConfig.min_linear_speed ({self.min_linear_speed}) must be <="
                f" max_linear_speed ({self.max_linear_speed})"
            )
        if self.inflation_radius < self.inscribed_radius:
            raise PlannerConfigError(
                f"PlannerConfig.inflation_radius ({self.inflation_radius} m) must be >= half the"
                f" robot width ({self.inscribed_radius} m)"
            )
        if self.sim_dt > self.sim_time:
            raise PlannerConfigError("PlannerConfig.sim_dt must be <= sim_time")
        steps = self.v_samples * self.w_samples * max(1, round(self.sim_time / self.sim_dt))
        if steps > MAX_ROLLOUT_STEPS:
            raise PlannerConfigError(
                f"PlannerConfig: v_samples x w_samples x sim_time/sim_dt = {steps} rollout steps"
                f" per cycle > {MAX_ROLLOUT_STEPS} (it would stall the control loop)"
            )
        reach = max(self.max_linear_speed, abs(self.min_linear_speed)) * self.sim_time
        half = reach + math.hypot(0.5 * self.robot_length, 0.5 * self.robot_width) + 0.6
        cells = math.ceil(2 * half / self.local_grid_resolution) ** 2
        if cells > MAX_FIELD_CELLS:
            raise PlannerConfigError(
                f"PlannerConfig: local_grid_resolution = {self.local_grid_resolution} m gives a "
                f"{cells}-cell obstacle grid > {MAX_FIELD_CELLS}; use a coarser resolution"
            )

    @property
    def inscribed_radius(self) -> float:
        """Half the robot width [m]: Nav2's inscribed radius."""
        return 0.5 * self.robot_width

    def replace(self, **changes: Any) -> PlannerConfig:
        """A validated copy with ``changes``; unknown names raise :class:`PlannerConfigError`."""
        known = set(self.__struct_fields__)
        unknown = sorted(set(changes) - known)
        if unknown:
            raise PlannerConfigError(
                f"unknown PlannerConfig field(s) {unknown}; known: {sorted(known)}"
            )
        return msgspec.structs.replace(self, **changes)
