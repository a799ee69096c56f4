"""Base Station parameters changed on the fly (thesis §5.3, "Configurations").

The thesis's station lets the operator set the remaining-distance tolerances used when
approaching goals, the teleoperation speed limits and the latency ceiling of the Tablet
watchdog (§5.3.4). `StationConfig` holds those, plus the planner's speed limits that the station
forwards to the robot (a ``config`` message), declared with their ranges (msgspec). They are kept
in the ``config:`` section of the station file (`station_file`), their one owner.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from typing import Annotated, ClassVar, Final

import msgspec

from interbot_core import schema
from interbot_core.schema import within
from interbot_core.supervisor import SupervisorConfig

logger = logging.getLogger(__name__)


class StationConfigError(ValueError):
    """A configuration value is outside its allowed range; the message names field and range."""


class StationConfig(schema.Declared, frozen=True):
    """Operator-tunable parameters (defaults: thesis Table 6.3 tolerances, 0.2 s ceiling).

    The speed ranges stay within the robot's own per-source limits
    (resources/config/interbot_mux.yaml: the station may offer less, never more); a tablet
    command is never older than 1 s when it drives (issue 11)."""

    ROOT: ClassVar[str] = "config"
    ERROR: ClassVar[type[Exception]] = StationConfigError

    # intermediate goals count as reached within this
    approach_tolerance: Annotated[float, within(0.05, 5.0, "m")] = 0.7
    goal_tolerance: Annotated[float, within(0.02, 2.0, "m")] = 0.25  # final goal position
    yaw_tolerance: Annotated[float, within(0.02, math.pi, "rad")] = 0.25  # final goal heading
    # keyboard, arrow pad and mouse joystick
    teleop_linear_max: Annotated[float, within(0.05, 0.5, "m/s")] = 0.4
    teleop_angular_max: Annotated[float, within(0.1, 1.5, "rad/s")] = 0.8
    # sent to the robot's planner (its default, Table 6.3)
    planner_linear_max: Annotated[float, within(0.05, 0.5, "m/s")] = 0.25
    planner_angular_max: Annotated[float, within(0.1, 1.5, "rad/s")] = 1.0
    # tablet speed commands older than this are discarded
    latency_ceiling: Annotated[float, within(0.05, 1.0, "s")] = 0.5

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


def _ranges() -> dict[str, tuple[float, float, str]]:
    info = msgspec.inspect.type_info(StationConfig)
    assert isinstance(info, msgspec.inspect.StructType)
    out = {}
    for f in info.fields:
        meta = f.type
        assert isinstance(meta, msgspec.inspect.Metadata)
        number = meta.type
        assert isinstance(number, msgspec.inspect.FloatType)
        assert number.ge is not None and number.le is not None and meta.extra is not None
        out[f.name] = (number.ge, number.le, str(meta.extra["unit"]))
    return out


RANGES: Final[Mapping[str, tuple[float, float, str]]] = _ranges()
"""Allowed closed range and unit of every field, read from the declaration (for the panel)."""
