"""Navigation parameters: one frozen, validated :class:`PlannerConfig`.

Defaults follow the thesis where it gives values (Table 6.3: maximum speeds 0.25 m/s and
1 rad/s, minimum linear speed 0, goal tolerances 0.5 m and 0.1 rad; robot footprint 0.60 x
0.55 m) and Nav2 / DWB elsewhere (inflation, progress checker, recoveries; see
shared/FIELD_NOTES.md "Navigation reference values"). Change values at run time with
``PlannerConfig.replace(**changes)`` (or ``Navigator.reconfigure``), which validates again.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from robot_daemon.planning.costmap import CostmapConfig
from robot_daemon.planning.global_planner import GlobalPlannerConfig


class PlannerConfigError(ValueError):
    """A navigation parameter is unknown or out of range; the message names it."""


# field -> (lowest allowed, highest allowed, lowest is inclusive). Closed, physically sensible
# bounds (issue 11): no value in them can exhaust memory or freeze the control loop (with
# `MAX_ROLLOUT_STEPS` and `MAX_FIELD_CELLS` below), from a file or a ``config`` message alike.
_RANGES: dict[str, tuple[float, float, bool]] = {
    "max_linear_speed": (0.05, 1.0, True),
    "min_linear_speed": (-0.5, 1.0, True),
    "max_angular_speed": (0.1, 3.0, True),
    "linear_acceleration": (0.05, 3.0, True),
    "angular_acceleration": (0.1, 10.0, True),
    "goal_xy_tolerance": (0.01, 2.0, True),
    "goal_yaw_tolerance": (0.01, math.pi, True),
    "approach_tolerance": (0.05, 5.0, True),
    "robot_length": (0.1, 2.0, True),
    "robot_width": (0.1, 2.0, True),
    "laser_x_offset": (-1.0, 1.0, True),
    "inflation_radius": (0.05, 3.0, True),
    "cost_scaling_factor": (0.1, 50.0, True),
    "obstacle_persistence": (0.0, 60.0, True),
    "obstacle_max_range": (0.5, 30.0, True),
    "raytrace_max_range": (0.5, 30.0, True),
    "planning_resolution": (0.025, 0.5, True),
    "cost_weight": (0.0, 1e4, True),
    "path_spacing": (0.05, 2.0, True),
    "replan_period": (0.1, 60.0, True),
    "sim_time": (0.3, 5.0, True),
    "sim_dt": (0.02, 0.5, True),
    "v_samples": (2, 41, True),
    "w_samples": (3, 61, True),
    "lookahead": (0.2, 5.0, True),
    "local_grid_resolution": (0.02, 0.2, True),
    "slowdown_clearance": (0.0, 2.0, True),
    "slowdown_min_fraction": (0.05, 1.0, True),
    "approach_slowdown_distance": (0.05, 5.0, True),
    "rotate_to_heading_angle": (0.1, math.pi, True),
    "yaw_gain": (0.1, 10.0, True),
    "min_rotation_speed": (0.0, 1.0, True),
    "progress_distance": (0.05, 5.0, True),
    "progress_timeout": (1.0, 300.0, True),
    "blocked_timeout": (1.0, 3600.0, True),
    "spin_angle": (0.0, 2 * math.pi, True),
    "backup_distance": (0.0, 1.0, True),
    "backup_speed": (0.02, 0.5, True),
    "wait_duration": (0.0, 120.0, True),
}
MAX_ROLLOUT_STEPS = 20_000
"""Most integration steps of one local-planner cycle, ``v_samples * w_samples * sim_time/sim_dt``
(the default is 3 465, about 10 ms here; the bound keeps a cycle well under 0.1 s)."""
MAX_FIELD_CELLS = 1_000_000
"""Most cells of the robot-centred obstacle grid (about 8 MB of float64)."""


@dataclass(frozen=True)
class PlannerConfig:
    """Everything the navigator, its planners and its costmap need (SI units)."""

    # Velocity limits, thesis Table 6.3 (rotational minimum -1 rad/s = -max_angular_speed).
    max_linear_speed: float = 0.25  # [m/s]
    min_linear_speed: float = 0.0  # [m/s] 0: the controller never reverses (recoveries may)
    max_angular_speed: float = 1.0  # [rad/s]
    linear_acceleration: float = 0.5  # [m/s^2]
    angular_acceleration: float = 2.0  # [rad/s^2]
    # Goal checking, thesis Table 6.3; approach tolerance of intermediate goals (§5.3.6).
    goal_xy_tolerance: float = 0.5  # [m]
    goal_yaw_tolerance: float = 0.1  # [rad]
    approach_tolerance: float = 0.7  # [m] Nav2 drops via-points within 0.7 m
    # Robot: rectangular footprint, centred on the base_link origin.
    robot_length: float = 0.60  # [m] along x
    robot_width: float = 0.55  # [m] along y
    laser_x_offset: float = 0.0  # [m] laser position ahead of base_link
    # Costmap (Nav2 inflation layer and obstacle layer).
    inflation_radius: float = 0.6  # [m]
    cost_scaling_factor: float = 5.0  # [1/m]
    obstacle_persistence: float = 2.0  # [s]
    obstacle_max_range: float = 4.0  # [m]
    raytrace_max_range: float = 5.0  # [m]
    allow_unknown: bool = False  # Nav2's allow_unknown (its default is True): see CostmapConfig
    # Global planner.
    planning_resolution: float = 0.1  # [m]
    cost_weight: float = 100.0
    path_spacing: float = 0.25  # [m]
    replan_period: float = 1.0  # [s]
    # Local planner (dynamic window approach).
    sim_time: float = 1.5  # [s] trajectory horizon
    sim_dt: float = 0.1  # [s] integration step of the rollouts
    v_samples: int = 11
    w_samples: int = 21
    lookahead: float = 1.0  # [m] carrot distance along the path
    local_grid_resolution: float = 0.05  # [m]
    slowdown_clearance: float = 0.3  # [m] below this footprint clearance the speed limit drops
    slowdown_min_fraction: float = 0.4  # speed limit at zero clearance, fraction of the maximum
    approach_slowdown_distance: float = 1.0  # [m] final approach: limit = max * d / this
    rotate_to_heading_angle: float = 1.2  # [rad] beyond this path-heading error, turn in place
    yaw_gain: float = 1.5  # [1/s] P gain of the final in-place rotation
    min_rotation_speed: float = 0.1  # [rad/s] rotation never slower than this until aligned
    # Progress checker and recoveries (Nav2 behaviour tree defaults).
    progress_distance: float = 0.5  # [m]
    progress_timeout: float = 10.0  # [s]
    blocked_timeout: float = 30.0  # [s] recoveries without progress -> "blocked"
    spin_angle: float = math.pi / 2  # [rad]
    backup_distance: float = 0.3  # [m]
    backup_speed: float = 0.1  # [m/s]
    wait_duration: float = 5.0  # [s]

    def __post_init__(self) -> None:
        for name, (low, high, inclusive) in _RANGES.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise PlannerConfigError(f"PlannerConfig.{name} must be a number, got {value!r}")
            above = value >= low if inclusive else value > low
            if not (math.isfinite(value) and above and value <= high):
                bracket = "[" if inclusive else "("
                raise PlannerConfigError(
                    f"PlannerConfig.{name} = {value!r} is outside {bracket}{low}, {high}]"
                )
        if not isinstance(self.allow_unknown, bool):
            raise PlannerConfigError("PlannerConfig.allow_unknown must be true or false")
        for name in ("v_samples", "w_samples"):
            if not isinstance(getattr(self, name), int):
                raise PlannerConfigError(f"PlannerConfig.{name} must be an integer")
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
        known = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise PlannerConfigError(
                f"unknown PlannerConfig field(s) {unknown}; known: {sorted(known)}"
            )
        return dataclasses.replace(self, **changes)

    def costmap_config(self) -> CostmapConfig:
        return CostmapConfig(
            inscribed_radius=self.inscribed_radius,
            inflation_radius=self.inflation_radius,
            cost_scaling_factor=self.cost_scaling_factor,
            obstacle_persistence=self.obstacle_persistence,
            obstacle_max_range=self.obstacle_max_range,
            raytrace_max_range=self.raytrace_max_range,
            allow_unknown=self.allow_unknown,
        )

    def global_planner_config(self) -> GlobalPlannerConfig:
        return GlobalPlannerConfig(
            planning_resolution=self.planning_resolution,
            cost_weight=self.cost_weight,
            sample_spacing=self.path_spacing,
        )
