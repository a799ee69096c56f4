"""Navigation for the robot daemon: costmap, global A*, DWA local planner and the navigator.

The Python counterpart of the thesis's Hybrid Motion Planner (§3.3, §4.2.3.2); see each module.
"""

from __future__ import annotations

from robot_daemon.planning.config import PlannerConfig, PlannerConfigError
from robot_daemon.planning.costmap import (
    INSCRIBED,
    LETHAL,
    Costmap,
    CostmapConfig,
    CostmapConfigError,
    inflation_cost,
)
from robot_daemon.planning.global_planner import (
    GlobalPlanner,
    GlobalPlannerConfig,
    GoalBlockedError,
    NoPathError,
    PlanningError,
    StartBlockedError,
)
from robot_daemon.planning.local_planner import DWAPlanner, LocalPlan, ObstacleField
from robot_daemon.planning.navigator import NavCommand, Navigator, NavState

__all__ = [
    "INSCRIBED",
    "LETHAL",
    "Costmap",
    "CostmapConfig",
    "CostmapConfigError",
    "DWAPlanner",
    "GlobalPlanner",
    "GlobalPlannerConfig",
    "GoalBlockedError",
    "LocalPlan",
    "NavCommand",
    "NavState",
    "Navigator",
    "NoPathError",
    "ObstacleField",
    "PlannerConfig",
    "PlannerConfigError",
    "PlanningError",
    "StartBlockedError",
    "inflation_cost",
]
