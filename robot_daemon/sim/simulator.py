"""The Interbot simulator: motors, encoders, laser, camera, BMS and people on a simulated clock.

``Simulator(grid, config, rng_seed)`` stands in for the robot's hardware (thesis §4.1): the
daemon writes ``set_cmd_vel`` (what the RoboteQ motor controller receives) and pulls sensor
outputs on demand — ``odometry()`` (encoder odometry in the drifting ``odom`` frame, REP-105),
``scan()`` (Hokuyo UTM-30LX, 40 Hz cadence via ``scan_due()``), ``camera_frame()`` (~10 Hz via
``camera_due()``) and ``battery()`` (BMS).

Time is simulated: ``step(dt)`` advances in fixed internal steps (``SimConfig.internal_dt``,
default 0.01 s) counted as integers, so runs are identical for a seed and independent of the
wall clock and of how often sensors are read (each noise source has its own Generator spawned
from the seed).

Per internal step: the drive's velocity loop (limits), the true motion for the odometry error
model, exact arc integration, collision check of the footprint against walls and people; on a
collision the robot is put at the last free pose along the step (bisection), stopped, and
``collisions`` is incremented once per contact (a new contact needs the robot to have backed off
by ``contact_hysteresis``). The robot never passes through a wall or a person.

GROUND TRUTH IS FOR METRICS ONLY: ``true_pose()`` and ``min_clearance()`` read the simulator's
map-frame truth. Never feed them to the robot's software (localisation, planning, control); the
robot sees the world only through ``odometry()``, ``scan()``, ``camera_frame()`` and ``battery()``.
"""

from __future__ import annotations

import logging
import math
from typing import Annotated, ClassVar

import msgspec
import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.backend import OdometryReading
from robot_daemon.sim.battery import Battery, BatteryConfig, BatteryState
from robot_daemon.sim.camera_sim import CameraConfig, CameraSim
from robot_daemon.sim.diff_drive import DiffDrive, DiffDriveConfig, RobotFootprint, integrate_arc
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim
from robot_daemon.sim.odometry_model import (
    OdometryErrorModel,
    WheelOdometry,
    true_body_velocity,
    true_track_width,
)
from robot_daemon.sim.people import Crowd, CrowdConfig
from robot_daemon.sim.world import RectObstacle, World

logger = logging.getLogger(__name__)

_BISECTION_STEPS = 10  # collision point to 1/1024 of an internal step
_EPS = 1e-9


class SimConfigError(ValueError):
    """A simulator parameter is invalid; the message names the field."""


class SimConfig(schema.Declared, frozen=True):
    """Everything configurable about the simulated robot and its world."""

    ROOT: ClassVar[str] = "SimConfig"
    ERROR: ClassVar[type[Exception]] = SimConfigError
    internal_dt: Annotated[float, Meta(ge=1e-4, le=0.1, extra={"unit": "s"})] = 0.01
    drive: DiffDriveConfig = msgspec.field(default_factory=DiffDriveConfig)
    footprint: RobotFootprint = msgspec.field(default_factory=RobotFootprint)
    odometry: OdometryErrorModel = msgspec.field(default_factory=OdometryErrorModel.calibrated)
    laser: LaserConfig = msgspec.field(default_factory=LaserConfig)
    camera: CameraConfig = msgspec.field(default_factory=CameraConfig)
    battery: BatteryConfig = msgspec.field(default_factory=BatteryConfig)
    crowd: CrowdConfig = msgspec.field(default_factory=CrowdConfig)
    obstacles: tuple[RectObstacle, ...] = ()
    glass: tuple[tuple[float, float, float, float], ...] = ()  # panes x0, y0, x1, y1 [m]
    n_people: Annotated[int, Meta(ge=0, le=200)] = 0  # people spawned on routes at start
    start_pose: Pose2D | None = None  # None: the most open point of the map, facing +x
    contact_hysteresis: Annotated[float, Meta(ge=0.0, le=0.5, extra={"unit": "m"})] = 0.02
    # [s] motor watchdog (RoboteQ default 1.0); None = off
    cmd_timeout: Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "s"})] | None = None


class Simulator:
    """A deterministic simulated Interbot in a static map with furniture and people."""

    def __init__(
        self, grid: OccupancyGrid, config: SimConfig | None = None, rng_seed: int = 0
    ) -> None:
        self.config = config = config or SimConfig()
        odom_seed, laser_seed, people_seed = np.random.SeedSequence(rng_seed).spawn(3)
        self.world = World(grid, config.obstacles, config.glass)
        self.drive = DiffDrive(config.drive)
        self._pose = config.start_pose or self._most_open_pose()
        self.odometry_model = WheelOdometry(
            config.odometry, config.drive.track_width, np.random.default_rng(odom_seed)
        )
        self.laser = LaserSim(self.world, config.laser, np.random.default_rng(laser_seed))
        self.camera = CameraSim(self.laser.caster, config.camera)
        self._battery = Battery(config.battery)
        self.crowd = Crowd(self.world, np.random.default_rng(people_seed), config.crowd)
        if config.n_people:
            self.crowd.spawn(config.n_people, robot=(self._pose, config.footprint))
        self._true_track = true_track_width(config.odometry, config.drive.track_width)
        self._ticks = 0
        self._pending = 0.0
        self._collisions = 0
        self._in_contact = False
        self._last_cmd_time = 0.0
        self._next_scan = 0.0
        self._next_frame = 0.0
        self._true_velocity = (0.0, 0.0)
        logger.info(
            "simulator on %s: start %s, odometry %s, %d people, seed %d",
            grid.source,
            self._pose,
            config.odometry,
            config.n_people,
            rng_seed,
        )

    def _most_open_pose(self) -> Pose2D:
        edt = self.world.edt_cells
        row, col = np.unravel_index(int(np.argmax(edt)), edt.shape)
        x, y = self.world.grid.cell_to_world(row - 2, col - 2)  # padded -> grid cell
        return Pose2D(float(x), float(y), 0.0)

    # --- clock ------------------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulated time [s] since start."""
        return self._ticks * self.config.internal_dt

    def step(self, dt: float) -> None:
        """Advance the simulation by dt [s] (in whole internal steps; a remainder carries over)."""
        if not (math.isfinite(dt) and dt >= 0):
            raise SimConfigError(f"Simulator.step needs a finite dt >= 0 s, got {dt!r}")
        self._pending += dt
        n = math.floor(self._pending / self.config.internal_dt + _EPS)
        self._pending = max(0.0, self._pending - n * self.config.internal_dt)
        for _ in range(n):
            self._substep()

    # --- inputs -----------------------------------------------------------------------------

    def set_cmd_vel(self, linear: float, angular: float) -> None:
        """Motor-driver input: body velocity command (clamped/rate-limited by the drive)."""
        self.drive.command(linear, angular)
        self._last_cmd_time = self.time

    def teleport(self, pose: Pose2D) -> None:
        """Move the true robot (kidnapping); odometry does not notice. Velocities are zeroed."""
        self._pose = pose
        self.drive.stop()
        self._in_contact = False
        logger.info("robot teleported to %s at %.2f s", pose, self.time)

    def add_obstacle(self, rect: RectObstacle) -> None:
        """Place a new static obstacle (furniture not in the robot's a-priori map)."""
        self.world.add_obstacle(rect)

    def add_person(self, route: list[tuple[float, float]], *, blocker: bool = False) -> int:
        """Add a person patrolling ``route`` [m]; returns the person id (see ``crowd``)."""
        return self.crowd.add_person(route, blocker=blocker)

    # --- outputs for the robot --------------------------------------------------------------

    def odometry(self) -> OdometryReading:
        """Encoder odometry: base_link in ``odom`` (drifts) and measured velocities."""
        linear, angular = self.odometry_model.velocity
        return OdometryReading(self.time, self.odometry_model.pose, linear, angular)

    def scan_due(self) -> bool:
        """True when the laser's 40 Hz period has elapsed since the last ``scan()``."""
        return self.time + _EPS >= self._next_scan

    def scan(self) -> LaserScan:
        """Ray-cast a scan now (stamped with sim time) from the laser on the true robot pose."""
        now = self.time
        period = self.config.laser.scan_period
        self._next_scan = (math.floor(now / period + _EPS) + 1) * period
        return self.laser.scan(self._pose, now, self.crowd.circles())

    def camera_due(self) -> bool:
        """True when the camera's frame period has elapsed since the last ``camera_frame()``."""
        return self.time + _EPS >= self._next_frame

    def camera_frame(self) -> npt.NDArray[np.uint8]:
        """A rendered BGR uint8 frame from the camera on the true robot pose."""
        period = self.config.camera.frame_period
        self._next_frame = (math.floor(self.time / period + _EPS) + 1) * period
        return self.camera.render(self._pose, self.crowd.circles())

    def battery(self) -> BatteryState:
        """The BMS report."""
        return self._battery.state()

    # --- METRICS ONLY: ground truth, never to be fed to the robot ---------------------------

    def true_pose(self) -> Pose2D:
        """GROUND TRUTH, METRICS AND TESTS ONLY: base_link in ``map``. Never feed to the robot."""
        return self._pose

    def true_velocity(self) -> tuple[float, float]:
        """GROUND TRUTH, METRICS ONLY: actual (linear [m/s], angular [rad/s]) of the last step."""
        return self._true_velocity

    @property
    def collisions(self) -> int:
        """METRICS: number of distinct collisions with walls, obstacles or people."""
        return self._collisions

    def min_clearance(self) -> float:
        """METRICS ONLY: distance [m] from the footprint to the nearest wall or person."""
        return self.world.footprint_clearance(
            self.config.footprint, self._pose, self.crowd.circles()
        )

    # --- internals --------------------------------------------------------------------------

    def _substep(self) -> None:
        cfg = self.config
        dt = cfg.internal_dt
        now = self.time
        if cfg.cmd_timeout is not None and now - self._last_cmd_time > cfg.cmd_timeout:
            self.drive.command(0.0, 0.0)
        if self._battery.cutoff:
            self.drive.stop()
        linear_cmd, angular_cmd = self.drive.advance(dt)
        linear, wheel_angular = true_body_velocity(
            cfg.odometry, cfg.drive.track_width, linear_cmd, angular_cmd
        )
        angular = wheel_angular * self.odometry_model.slip_factor(wheel_angular)
        fraction = 1.0
        if linear != 0.0 or angular != 0.0:
            fraction = self._move(linear, angular, dt)
        self._true_velocity = (linear * fraction, angular * fraction)
        half = 0.5 * wheel_angular * self._true_track
        arc = fraction * dt
        self.odometry_model.update((linear - half) * arc, (linear + half) * arc, dt)
        self._ticks += 1
        self._battery.step(dt, linear * fraction, angular * fraction, self.time)
        self.crowd.step(dt, self._pose, cfg.footprint)

    def _move(self, linear: float, angular: float, dt: float) -> float:
        """Move the true pose along the arc; return the fraction of dt completed."""
        fp = self.config.footprint
        circles = self.crowd.circles()
        candidate = integrate_arc(self._pose, linear, angular, dt)
        if not self.world.footprint_collides(fp, candidate, circles):
            if self._in_contact and not self.world.footprint_collides(
                fp.inflated(self.config.contact_hysteresis), candidate, circles
            ):
                self._in_contact = False
            self._pose = candidate
            return 1.0
        lo, hi = 0.0, 1.0
        for _ in range(_BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            if self.world.footprint_collides(
                fp, integrate_arc(self._pose, linear, angular, mid * dt), circles
            ):
                hi = mid
            else:
                lo = mid
        if lo > 0.0:
            self._pose = integrate_arc(self._pose, linear, angular, lo * dt)
        self.drive.stop()
        if not self._in_contact:
            self._collisions += 1
            logger.info("collision %d at %.2f s, pose %s", self._collisions, self.time, self._pose)
        self._in_contact = True
        return lo
