"""`interbot calibrate odometry`: thesis Test Scenario 1 (§6.1) and the odometry correction.

The robot (here the simulator, with deliberately mis-set wheel radius and track: an
`OdometryErrorModel` with known scale errors) drives the Test Scenario 1 routine: a straight run
forward, a pure rotation of 2π counter-clockwise, the straight run back and 2π clockwise, each
from standstill to standstill, with speed commands through the velocity multiplexer as in the
thesis. Each section is measured twice: by the encoders (odometry) and by the scan matcher
against the map (the reference; ground truth is printed only as a check of the method).
`robot_daemon.calibration.estimate_correction` turns the two into corrected kinematic parameters
(distance ratio -> wheel radius, rotation ratio -> track); the routine is then run again with
the corrected parameters, and both runs are printed as thesis Tables 6.1/6.2.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, ClassVar

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.occupancy_grid import MapLoadError, OccupancyGrid, load_map
from interbot_core.topological_map import TopologicalMapError, load_topological_map
from robot_daemon.calibration import (
    CalibrationError,
    KinematicParameters,
    OdometryCorrection,
    SegmentKind,
    SegmentMeasurement,
    estimate_correction,
    format_table,
)
from robot_daemon.config import DEFAULT_MAP, DEFAULT_TOPO
from robot_daemon.localisation.localiser import LocaliserConfig, LocaliserState
from robot_daemon.localisation.scan_matcher import ScanMatcherConfig
from robot_daemon.safety.motion_guard import default_guard_config
from robot_daemon.sim.diff_drive import DiffDriveConfig
from robot_daemon.sim.odometry_model import OdometryConfigError, OdometryErrorModel
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.sim_backend import SimBackend
from robot_daemon.stack import RobotStack, StackConfig

logger = logging.getLogger(__name__)

EXIT_USAGE = 2
EXIT_FAILED = 1
STACK_DT = 0.02  # [s] simulated time per pass of the control loop (the daemon's 50 Hz)
TELEOP_TOPIC = "station_vel"  # commands enter through the multiplexer, as in the thesis
DEFAULT_START_NODE = 1  # SW corner of ISR floor 0, facing east along the south corridor


Metres = Annotated[float, Meta(ge=0.5, le=30.0, extra={"unit": "m"})]
Seconds = Annotated[float, Meta(ge=0.5, le=10.0, extra={"unit": "s"})]


class RoutineConfig(schema.Declared, frozen=True, kw_only=True):
    """Test Scenario 1 as driven here (thesis: 26 m corridor, 0.6 m/s and 0.6 rad/s)."""

    ROOT: ClassVar[str] = "RoutineConfig"
    ERROR: ClassVar[type[Exception]] = CalibrationError
    distance: Metres = 5.0  # each straight run
    linear_speed: Annotated[float, Meta(ge=0.05, le=0.8, extra={"unit": "m/s"})] = 0.4
    angular_speed: Annotated[float, Meta(ge=0.1, le=1.5, extra={"unit": "rad/s"})] = 0.6
    turns: Annotated[float, Meta(ge=0.25, le=5.0)] = 1.0  # full turns per rotation section
    settle: Seconds = 1.5  # standstill before and after each section
    # reference estimates averaged at standstill (at most ``settle``)
    average_window: Annotated[float, Meta(ge=0.1, le=10.0, extra={"unit": "s"})] = 0.6
    # a section aborts after this many times its nominal time
    timeout_factor: Annotated[float, Meta(ge=1.2, le=10.0)] = 2.0

    def check(self) -> None:
        if self.average_window > self.settle:
            raise CalibrationError(
                f"RoutineConfig.average_window = {self.average_window} s is longer than "
                f"settle = {self.settle} s"
            )


@dataclass
class _Track:
    """Unwrapped yaw of one pose source, accumulated from successive samples."""

    pose: Pose2D | None = None
    yaw: float = 0.0  # [rad] unwrapped

    def add(self, pose: Pose2D) -> None:
        if self.pose is not None:
            self.yaw += angle_diff(pose.yaw, self.pose.yaw)
        self.pose = pose


@dataclass
class _Snapshot:
    odom: Pose2D
    odom_yaw: float
    ref: Pose2D
    ref_yaw: float
    truth: Pose2D
    truth_yaw: float


@dataclass
class SimulatedRobot:
    """Simulator + robot stack on simulated time, localised at ``start`` by the operator."""

    grid: OccupancyGrid
    start: Pose2D
    model: OdometryErrorModel
    seed: int
    now: float = 0.0
    _odom: _Track = field(default_factory=_Track)
    _ref: _Track = field(default_factory=_Track)
    _truth: _Track = field(default_factory=_Track)
    _ref_samples: list[tuple[float, Pose2D, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.sim = Simulator(
            self.grid,
            SimConfig(start_pose=self.start, n_people=0, odometry=self.model),
            rng_seed=self.seed,
        )
        self.backend = SimBackend(self.sim, scan_rate_hz=10.0, camera_rate_hz=0.0)
        # Pure scan matching (as the thesis's Hector SLAM, no odometry fusion) and a fixed map,
        # so the reference does not inherit the odometry's error.
        # This simulated robot's world is the grid itself, whose walls lie on cell faces: the
        # reference matcher uses that wall model (the daemon's default, cell centres, suits maps
        # built from laser end points and would bias this reference by half a cell).
        localiser = LocaliserConfig(
            odom_blend=False, map_update=False, matcher=ScanMatcherConfig(surface="cell_face")
        )
        # The routine backs up along its straight section; the collision monitor caps blind
        # reversing (nothing behind a 270-degree laser) and would change the very speed the
        # calibration measures against. This robot is simulated only, so the monitor is off.
        guard = default_guard_config()
        guard = guard.replace(monitor=msgspec.structs.replace(guard.monitor, enabled=False))
        self.config = StackConfig(localiser=localiser, motion_guard=guard)
        self.stack = RobotStack(self.grid, self.backend, self.config)
        self._mount_inv = self.config.laser_mount.inverse()
        self.stack.set_initial_pose(self.start, 0.0)
        self._last_estimate: object = None

    def step(self, linear: float, angular: float) -> None:
        self.now = round(self.now + STACK_DT, 9)
        self.backend.advance(self.now)
        self.stack.on_twist(TELEOP_TOPIC, linear, angular, self.now)
        self.stack.step(self.now)
        odom = self.stack.last_odometry
        if odom is not None:
            self._odom.add(odom.pose)
        self._truth.add(self.sim.true_pose())  # METRICS ONLY: printed as a check
        estimate = self.stack.last_estimate
        if estimate is not None and estimate is not self._last_estimate:
            self._last_estimate = estimate
            if estimate.state is not LocaliserState.OK or estimate.pose is None:
                raise CalibrationError(
                    f"localisation {estimate.state.value} at t={self.now:.1f} s: the scan "
                    "matcher cannot serve as the reference; start where the map has features"
                )
            base = estimate.pose.compose(self._mount_inv)
            self._ref.add(base)
            self._ref_samples.append((self.now, base, self._ref.yaw))

    def hold(self, seconds: float) -> None:
        for _ in range(round(seconds / STACK_DT)):
            self.step(0.0, 0.0)

    def snapshot(self, window: float) -> _Snapshot:
        """Poses now, the reference averaged over the last ``window`` seconds at standstill."""
        recent = [s for s in self._ref_samples if s[0] >= self.now - window - 1e-9]
        if not recent or self._odom.pose is None or self._truth.pose is None:
            raise CalibrationError("no scan-matcher estimate at standstill")
        x = sum(s[1].x for s in recent) / len(recent)
        y = sum(s[1].y for s in recent) / len(recent)
        yaw = sum(s[2] for s in recent) / len(recent)
        return _Snapshot(
            self._odom.pose,
            self._odom.yaw,
            Pose2D(x, y, yaw),
            yaw,
            self._truth.pose,
            self._truth.yaw,
        )

    @property
    def odom_yaw(self) -> float:
        return self._odom.yaw

    @property
    def odom_pose(self) -> Pose2D:
        if self._odom.pose is None:
            raise CalibrationError("no odometry yet")
        return self._odom.pose


def _along(start: Pose2D, end: Pose2D) -> float:
    """Signed distance from start to end along the start heading [m]."""
    return end.relative_to(start).x


def drive_section(
    robot: SimulatedRobot, kind: SegmentKind, target: float, routine: RoutineConfig
) -> SegmentMeasurement:
    """Drive one section until the odometry reports ``target`` (m or rad, signed); measure it."""
    robot.hold(routine.settle)
    before = robot.snapshot(routine.average_window)
    sign = 1.0 if target > 0 else -1.0
    if kind is SegmentKind.STRAIGHT:
        command = sign * routine.linear_speed
        cmd = (command, 0.0)
    else:
        command = sign * routine.angular_speed
        cmd = (0.0, command)
    limit = routine.timeout_factor * abs(target / command) + 2.0
    t0 = robot.now
    while True:
        if kind is SegmentKind.STRAIGHT:
            progress = _along(before.odom, robot.odom_pose)
        else:
            progress = robot.odom_yaw - before.odom_yaw
        if sign * progress >= abs(target):
            break
        if robot.now - t0 > limit:
            raise CalibrationError(
                f"{kind.value} section did not reach {target:.2f} in {limit:.0f} s "
                "(blocked? start where there is room)"
            )
        robot.step(*cmd)
    duration = robot.now - t0
    robot.hold(routine.settle)
    after = robot.snapshot(routine.average_window)
    return SegmentMeasurement(
        kind,
        command,
        duration,
        odom_distance=_along(before.odom, after.odom),
        odom_rotation=after.odom_yaw - before.odom_yaw,
        ref_distance=_along(before.ref, after.ref),
        ref_rotation=after.ref_yaw - before.ref_yaw,
        truth_distance=_along(before.truth, after.truth),
        truth_rotation=after.truth_yaw - before.truth_yaw,
    )


def run_routine(robot: SimulatedRobot, routine: RoutineConfig) -> list[SegmentMeasurement]:
    """Sections 1-4 of Test Scenario 1: forward, 2π CCW, back, 2π CW."""
    turn = routine.turns * math.tau
    plan = [
        (SegmentKind.STRAIGHT, routine.distance),
        (SegmentKind.ROTATION, turn),
        (SegmentKind.STRAIGHT, -routine.distance),
        (SegmentKind.ROTATION, -turn),
    ]
    return [drive_section(robot, kind, target, routine) for kind, target in plan]


def corrected_model(
    model: OdometryErrorModel, correction: OdometryCorrection
) -> OdometryErrorModel:
    """The simulated robot after its believed radii and track are multiplied by the correction.

    ``wheel_scale = believed / true radius`` and ``track_scale = believed / true track``, so
    both are multiplied by the correction of the believed value.
    """
    return OdometryErrorModel(
        model.wheel_scale_left * correction.left_scale,
        model.wheel_scale_right * correction.right_scale,
        model.track_scale * correction.track_scale,
        model.noise_per_sqrt_m,
    )


@dataclass(frozen=True)
class CalibrationReport:
    before: list[SegmentMeasurement]
    after: list[SegmentMeasurement]
    correction: OdometryCorrection
    believed: KinematicParameters
    proposed: KinematicParameters
    model: OdometryErrorModel

    def max_error(self, segments: list[SegmentMeasurement], truth: bool = False) -> float:
        if truth:
            return max(
                abs(s.odom_motion - (s.truth_motion or 0.0)) / abs(s.truth_motion or 1.0)
                for s in segments
            )
        return max(s.error_rate for s in segments)

    def figures(self) -> dict[str, Any]:
        m = self.model
        return {
            "sim_wheel_scale": [m.wheel_scale_left, m.wheel_scale_right],
            "sim_track_scale": m.track_scale,
            "left_scale": round(self.correction.left_scale, 5),
            "right_scale": round(self.correction.right_scale, 5),
            "wheel_radius_scale": round(self.correction.wheel_radius_scale, 5),
            "track_scale": round(self.correction.track_scale, 5),
            "true_wheel_radius_scale": round(1.0 / m.mean_wheel_scale, 5),
            "true_track_scale": round(1.0 / m.track_scale, 5),
            "wheel_radius_m": [self.believed.wheel_radius, round(self.proposed.wheel_radius, 5)],
            "wheel_radius_left_m": round(self.proposed.wheel_radius_left, 5),
            "wheel_radius_right_m": round(self.proposed.wheel_radius_right, 5),
            "track_m": [self.believed.track, round(self.proposed.track, 5)],
            "max_error_before": round(self.max_error(self.before), 5),
            "max_error_after": round(self.max_error(self.after), 5),
            "max_truth_error_after": round(self.max_error(self.after, truth=True), 5),
            "fit_rms": round(self.correction.residual_rms, 6),
        }

    def text(self) -> str:
        b, p, c = self.believed, self.proposed, self.correction
        lines = [
            format_table("Before calibration (cf. thesis Table 6.1)", self.before),
            "",
            "Proposed kinematic parameters (from odometry vs scan matcher):",
            f"  wheel_radius {b.wheel_radius:.5f} m -> {p.wheel_radius:.5f} m"
            f" (x{c.wheel_radius_scale:.4f}; left x{c.left_scale:.4f}, right x{c.right_scale:.4f})",
            f"  track        {b.track:.5f} m -> {p.track:.5f} m (x{c.track_scale:.4f})",
            f"  check against the simulator's truth: radius x{1 / self.model.mean_wheel_scale:.4f},"
            f" track x{1 / self.model.track_scale:.4f}",
            "  for robot.yaml (hardware.motors):",
            f"    wheel_radius_left: {p.wheel_radius_left:.5f}",
            f"    wheel_radius_right: {p.wheel_radius_right:.5f}",
            f"    track: {p.track:.5f}",
            "",
            format_table("After calibration, re-run (cf. thesis Table 6.2)", self.after),
        ]
        return "\n".join(lines)


def calibrate_sim(
    grid: OccupancyGrid,
    start: Pose2D,
    model: OdometryErrorModel,
    seed: int = 1,
    routine: RoutineConfig | None = None,
) -> CalibrationReport:
    """Run the routine, estimate the correction, apply it and run the routine again."""
    routine = routine or RoutineConfig()
    drive = DiffDriveConfig()
    believed = KinematicParameters(drive.wheel_radius, drive.wheel_radius, drive.track_width)
    before = run_routine(SimulatedRobot(grid, start, model, seed), routine)
    correction = estimate_correction(before, believed.track)
    fixed = corrected_model(model, correction)
    after = run_routine(SimulatedRobot(grid, start, fixed, seed + 1), routine)
    return CalibrationReport(before, after, correction, believed, correction.apply(believed), model)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="WHAT")
    p = sub.add_parser("odometry", help="Test Scenario 1: correct wheel radius and track")
    p.add_argument(
        "--sim-wheel-radius-error",
        type=float,
        default=5.0,
        metavar="P",
        help="simulated robot: believed wheel radius P %% larger than the true one (default 5)",
    )
    p.add_argument(
        "--sim-track-error",
        type=float,
        default=4.0,
        metavar="P",
        help="simulated robot: believed track P %% larger than the true one (default 4)",
    )
    p.add_argument("--seed", type=int, default=1, help="simulation seed")
    p.add_argument("--distance", type=float, default=5.0, help="straight run [m] (default 5)")
    p.add_argument("--map", dest="map_yaml", type=Path, help="map_server YAML (ISR floor 0)")
    p.add_argument("--topo", dest="topo_yaml", type=Path, help="topological map YAML")
    p.add_argument("--start-node", type=int, default=DEFAULT_START_NODE, help="start node id")
    p.add_argument("--json", action="store_true", help="last line: one JSON object")


def run(args: argparse.Namespace) -> int:
    try:
        model = OdometryErrorModel(
            1.0 + args.sim_wheel_radius_error / 100.0,
            1.0 + args.sim_wheel_radius_error / 100.0,
            1.0 + args.sim_track_error / 100.0,
            noise_per_sqrt_m=0.002,
        )
        routine = RoutineConfig(distance=args.distance)
        grid = load_map(args.map_yaml or DEFAULT_MAP)
        topo = load_topological_map(args.topo_yaml or DEFAULT_TOPO)
        start = topo.node(args.start_node).pose
        report = calibrate_sim(grid, start, model, args.seed, routine)
    except (OdometryConfigError, CalibrationError, MapLoadError, TopologicalMapError) as exc:
        print(f"interbot calibrate odometry: {exc}", file=sys.stderr)
        return EXIT_USAGE if not isinstance(exc, CalibrationError) else EXIT_FAILED
    print(report.text())
    if args.json:
        print(json.dumps(report.figures(), sort_keys=True))
    return 0
