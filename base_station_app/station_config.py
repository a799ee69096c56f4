"""Base Station parameters changed on the fly (thesis §5.3, "Configurations").

The thesis's station lets the operator set the remaining-distance tolerances used when
approaching goals, the teleoperation speed limits and the latency ceiling of the Tablet
watchdog (§5.3.4). `StationConfig` holds those, plus the planner's speed limits that the station
forwards to the robot (a ``config`` message), validated in the constructor. `from_mapping` reads
values saved with QSettings, falling back to the default for a missing or invalid entry (and
logging why), so a hand-edited settings file never stops the station from starting.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any, Final

from interbot_core.supervisor import SupervisorConfig

logger = logging.getLogger(__name__)


class StationConfigError(ValueError):
    """A configuration value is outside its allowed range; the message names field and range."""


RANGES: Final[Mapping[str, tuple[float, float, str]]] = {
    "approach_tolerance": (0.05, 5.0, "m"),
    "goal_tolerance": (0.02, 2.0, "m"),
    "yaw_tolerance": (0.02, math.pi, "rad"),
    "teleop_linear_max": (0.05, 0.5, "m/s"),
    "teleop_angular_max": (0.1, 1.5, "rad/s"),
    "planner_linear_max": (0.05, 0.5, "m/s"),
    "planner_angular_max": (0.1, 1.5, "rad/s"),
    "latency_ceiling": (0.05, 1.0, "s"),
}
"""Allowed closed range and unit of every field. The speed ranges stay within the robot's own
per-source limits (resources/config/interbot_mux.yaml: the station may offer less, never more);
a tablet command is never older than 1 s when it drives (issue 11)."""


@dataclass(frozen=True)
class StationConfig:
    """Operator-tunable parameters (defaults: thesis Table 6.3 tolerances, 0.2 s ceiling)."""

    approach_tolerance: float = 0.7  # [m] intermediate goals count as reached within this
    goal_tolerance: float = 0.25  # [m] final goal position
    yaw_tolerance: float = 0.25  # [rad] final goal heading
    teleop_linear_max: float = 0.4  # [m/s] keyboard, arrow pad and mouse joystick
    teleop_angular_max: float = 0.8  # [rad/s]
    planner_linear_max: float = 0.25  # [m/s] sent to the robot's planner (its default, Table 6.3)
    planner_angular_max: float = 1.0  # [rad/s]
    latency_ceiling: float = 0.5  # [s] tablet speed commands older than this are discarded

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            lo, hi, unit = RANGES[f.name]
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise StationConfigError(f"{f.name} must be a number [{unit}], got {value!r}")
            if not (math.isfinite(value) and lo <= value <= hi):
                raise StationConfigError(
                    f"{f.name} = {value!r} {unit} is outside the allowed range [{lo:g}, {hi:g}] {unit}"
                )
            object.__setattr__(self, f.name, float(value))

    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> StationConfig:
        """Build from saved values; a missing, malformed or out-of-range entry keeps its default."""
        kwargs: dict[str, float] = {}
        for f in fields(cls):
            if f.name not in values:
                continue
            raw = values[f.name]
            try:
                value = float(raw)
                cls(**{f.name: value})  # validate this field alone
            except (TypeError, ValueError) as exc:
                logger.warning("ignoring saved setting %s=%r: %s", f.name, raw, exc)
                continue
            kwargs[f.name] = value
        return cls(**kwargs)

    def supervisor_config(self, request_timeout: float = 120.0) -> SupervisorConfig:
        return SupervisorConfig(
            approach_tolerance=self.approach_tolerance,
            goal_tolerance=self.goal_tolerance,
            yaw_tolerance=self.yaw_tolerance,
            request_timeout=request_timeout,
        )

    def planner_params(self) -> dict[str, bool | int | float | str]:
        """The ``config`` message for the robot's planner (names of its `PlannerConfig` fields)."""
        return {
            "max_linear_speed": self.planner_linear_max,
            "max_angular_speed": self.planner_angular_max,
            "approach_tolerance": self.approach_tolerance,
            "goal_xy_tolerance": self.goal_tolerance,
            "goal_yaw_tolerance": self.yaw_tolerance,
        }
