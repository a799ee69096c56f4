"""The robot's motion guard: assisted teleoperation before the multiplexer, the collision
monitor after it.

`RobotStack` holds one `MotionGuard` and calls it in three places (a few lines each):

* every new scan: `on_scan` (the monitor re-evaluates its zones);
* every joystick command on ``station_vel`` / ``tablet_vel``: `on_teleop` replaces the command
  by the assisted one when assistance is on for that input (tablet on by default; the station's
  operator switches ``station_vel`` with the ``teleop_assist`` topic);
* every command to the motors: `limit` passes the multiplexer's output through the collision
  monitor, whatever its source (planner, tablet, station).

`report` is what the station shows the person driving (topic ``safety``).
Configuration: ``resources/config/collision_monitor.yaml`` (Nav2 Collision Monitor layout).

NOT A CERTIFIED SAFETY SYSTEM (see `robot_daemon.safety`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.velocity_mux import MuxOutput
from robot_daemon import jit
from robot_daemon.safety.assisted_teleop import (
    TELEOP_INPUTS,
    AssistConfig,
    AssistedTeleop,
    AssistResult,
)
from robot_daemon.safety.collision_monitor import (
    CollisionMonitor,
    CollisionMonitorConfig,
    MonitorResult,
    SafetyConfigError,
)

DEFAULT_SAFETY_YAML = (
    Path(__file__).resolve().parents[2] / "resources" / "config" / "collision_monitor.yaml"
)


def load_safety_config(path: Path | str) -> MotionGuardConfig:
    """Parse and validate the safety YAML (sections ``collision_monitor``, ``assisted_teleop``)."""
    data = schema.read_yaml(path, SafetyConfigError, "safety configuration")
    if not isinstance(data, dict) or "collision_monitor" not in data:
        raise SafetyConfigError(f"{path}: needs a 'collision_monitor' section")
    unknown = set(data) - {"collision_monitor", "assisted_teleop"}
    if unknown:
        raise SafetyConfigError(f"{path}: unknown section(s) {sorted(unknown)}")
    monitor = CollisionMonitorConfig.from_mapping(data["collision_monitor"], str(path))
    assist = AssistConfig.from_mapping(data.get("assisted_teleop") or {}, str(path))
    return MotionGuardConfig(monitor, assist)


@dataclass(frozen=True)
class MotionGuardConfig:
    monitor: CollisionMonitorConfig
    assist: AssistConfig = field(default_factory=AssistConfig)

    def replace(self, **changes: object) -> MotionGuardConfig:
        return dataclasses.replace(self, **changes)  # type: ignore[arg-type]


@functools.cache
def default_guard_config() -> MotionGuardConfig:
    """The configuration in ``resources/config/collision_monitor.yaml`` (read once; frozen)."""
    return load_safety_config(DEFAULT_SAFETY_YAML)


@dataclass(frozen=True)
class SafetyReport:
    """The monitor's and the assistance's state for the person driving."""

    zone: str
    zone_name: str
    distance: float  # [m] (inf: nothing within range)
    time_to_contact: float  # [s] (inf: none within the horizon)
    scale: float
    assisted: tuple[str, ...]
    assist_mode: str  # of the last assisted command


class MotionGuard:
    """Assisted teleoperation + collision monitor on one laser (see the module docstring)."""

    def __init__(self, config: MotionGuardConfig, laser_mount: Pose2D) -> None:
        self.config = config
        self.monitor = CollisionMonitor(config.monitor, laser_mount)
        self.assistant = AssistedTeleop(config.assist)
        self._assisted = {name: name in config.assist.inputs for name in TELEOP_INPUTS}
        self.last_assist: AssistResult | None = None
        self.interventions = 0  # commands the monitor reduced (since start)

    def on_scan(self, scan: LaserScan, now: float) -> None:
        self.monitor.on_scan(scan, now)

    def assisted(self, topic: str) -> bool:
        return self._assisted.get(topic, False)

    def set_assist(self, topic: str, enabled: bool) -> bool:
        """Switch assistance for ``topic``; returns True if that changed anything."""
        if topic not in self._assisted:
            raise SafetyConfigError(
                f"assistance applies to {', '.join(TELEOP_INPUTS)}, not {topic!r}"
            )
        changed = self._assisted[topic] != enabled
        self._assisted[topic] = enabled
        return changed

    def on_teleop(
        self, topic: str, linear: float, angular: float, now: float
    ) -> tuple[float, float]:
        """The command to give the multiplexer for a joystick command on ``topic``."""
        finite = math.isfinite(linear) and math.isfinite(angular)
        if not finite or not self._assisted.get(topic, False) or not self.monitor.fresh(now):
            return linear, angular  # no fresh scan: the monitor below stops the robot anyway
        px, py = self.monitor.points
        result = self.assistant.assist(linear, angular, px, py)
        self.last_assist = result
        return result.linear, result.angular

    def limit(self, output: MuxOutput, now: float) -> MuxOutput:
        """The multiplexer's output after the collision monitor."""
        result: MonitorResult = self.monitor.update(output.linear, output.angular, now)
        if (result.linear, result.angular) == (output.linear, output.angular):
            return output
        self.interventions += 1
        reason = (
            f"{output.reason}; collision monitor: {result.zone}"
            if output.reason
            else (f"collision monitor: {result.zone}")
        )
        return MuxOutput(result.linear, result.angular, output.source, reason, output.active_locks)

    def report(self) -> SafetyReport:
        last = self.monitor.last
        return SafetyReport(
            last.zone,
            last.zone_name,
            last.distance,
            last.time_to_contact,
            last.scale,
            tuple(name for name, on in self._assisted.items() if on),
            self.last_assist.mode if self.last_assist is not None else "idle",
        )


@jit.on_warm_up("safety")
def _warm_up() -> None:
    """The default guard on a scan with a wall ahead, under commands that take every path of
    the monitor and the assistance (approach along an arc, a turn on the spot, a stop zone,
    an assisted tablet drive and turn): every kernel with its types."""
    guard = MotionGuard(default_guard_config(), Pose2D(0.2, 0.0, 0.0))
    ranges = np.full(181, 0.5, dtype=np.float32)
    scan = LaserScan(0.0, -math.pi / 2, math.pi / 180, 0.02, 30.0, ranges)
    for linear, angular in ((0.2, 0.0), (0.2, 0.3), (0.0, 0.5), (-0.1, 0.0)):
        guard.on_scan(scan, 0.0)
        guard.limit(MuxOutput(linear, angular, "planner_vel", "", ()), 0.0)
        guard.on_teleop("tablet_vel", linear, angular, 0.0)
    guard.on_scan(dataclasses.replace(scan, ranges=np.full(181, 0.2, dtype=np.float32)), 0.1)
    guard.limit(MuxOutput(0.1, 0.2, "planner_vel", "", ()), 0.1)
