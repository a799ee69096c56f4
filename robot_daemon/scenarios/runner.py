"""The whole robot stack and the Base Station's logic, headless on simulated time.

By default the simulator runs in its OWN building (`robot_daemon.sim.realistic_world`): the
map's source drawn again at 2 cm with walls a few centimetres off, clutter, changed doors and
glass, a UTM-30LX error model, odometry with slip, and an initial pose set by a person (up to
0.3 m and 10 degrees off). ``ScenarioOptions.ideal_world`` keeps the old best case (world = map,
exact initial pose) for comparison.

`SimulatedSystem` wires what runs on three machines in the thesis into one loop: the simulator
(the robot's body and sensors), the `RobotStack` (the Processing Unit: localiser, navigator,
multiplexer) stepped at the daemon's 50 Hz, and the station's `Supervisor` driven at the
``clock()`` period of 100 ms, given what the station is given (`SimulatedSystem.station_view`),
whose route/pause/cancel events go to the stack as the zenoh link would carry them. `Metrics`
samples the simulator's ground truth, for figures only: nothing from it reaches the robot.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import numpy as np

from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.route_planner import RoutePlanner
from interbot_core.supervisor import (
    Event,
    PauseNavigation,
    RequestShown,
    RobotCondition,
    RouteCancelled,
    RouteStarted,
    Supervisor,
    SupervisorConfig,
    TaskFinished,
    TourStopReached,
)
from interbot_core.topics import RouteMsg
from interbot_core.topological_map import TopologicalMap, load_topological_map
from robot_daemon import jit
from robot_daemon.config import DEFAULT_MAP, DEFAULT_TOPO, LocaliserSettings
from robot_daemon.localisation.localiser import LocaliserConfig, LocaliserState
from robot_daemon.localisation.wall_model import wall_model_setting
from robot_daemon.scenarios.map_echo import NEAR_M as ECHO_NEAR_M
from robot_daemon.scenarios.map_echo import MapEcho, nees, pose_error
from robot_daemon.sim.laser_sim import LaserConfig
from robot_daemon.sim.odometry_model import OdometryErrorModel
from robot_daemon.sim.realistic_world import SimWorldSpec, build_sim_world, plan_beside
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.sim.world import RectObstacle
from robot_daemon.sim_backend import SimBackend
from robot_daemon.stack import STOP_TOPIC, RobotStack, StackConfig

if TYPE_CHECKING:
    from robot_daemon.recording.scenario_recording import ScenarioRecorder


STACK_DT = 0.05  # [s] loop period headless (the daemon runs 50 Hz; controller and localiser 10 Hz)
SIM_DT = 0.05  # [s] simulator substep: 2.5 cm at 0.5 m/s; collisions are bisected within it
CLOCK_DT = 0.1  # [s] the Base Station's clock() period (thesis §5.3.6)


@dataclass(frozen=True)
class ScenarioOptions:
    map_yaml: Path = DEFAULT_MAP
    topo_yaml: Path = DEFAULT_TOPO
    seed: int = 1
    people: int = 4
    odometry: str = "realistic"  # the ideal world uses "calibrated" in its place
    max_sim_time: float = 3600.0  # [s]
    ideal_world: bool = False  # True: the simulator's world IS the map, initial pose exact
    cold_start: bool = False  # kidnap scenario: start with the pose unset (issue 16)
    # kidnap scenario: a robot kidnapped standing at a tour stop stays idle (nobody asks for
    # the next leg; by default the station's supervisor hands it on after a dwell)
    idle_after_kidnap: bool = False
    # kidnap scenario --cold-start: nobody presses "Relocalise" at power-on (the robot searches
    # standing still; by default the operator presses it at once)
    idle_at_power_on: bool = False
    recorder: ScenarioRecorder | None = None  # --record FILE.mcap (robot_daemon/recording)


def daemon_localiser_config() -> LocaliserConfig:
    """The localiser as the daemon configures it by default: its wall model
    (``localiser.map_surface``, learnt from the scans), the same as on the robot: never one
    chosen to suit the simulator (issue 12)."""
    matcher, wall_model = wall_model_setting(LocaliserSettings().map_surface)
    return LocaliserConfig(matcher=matcher, wall_model=wall_model)


@dataclass
class ScenarioResult:
    """A scenario's table (thesis form) and its figures (the JSON line)."""

    name: str
    table: str
    figures: dict[str, Any]


# Issue 12: a pose this far from the truth must not be reported ok (a "silent failure").
SILENT_FAILURE_M = 0.3  # [m]
SILENT_FAILURE_RAD = math.radians(10.0)
INITIAL_POSE_MAX_ERROR = (0.3, math.radians(10.0))  # [m], [rad] a person setting the pose
CHI2_95_3DOF = 7.815  # 95 % quantile of chi-square with 3 degrees of freedom


def person_set_pose_error(rng: np.random.Generator) -> Pose2D:
    """How far off a person sets the initial pose: 0.1-0.3 m in any direction, 3-10 degrees.

    Not smaller than 0.1 m / 3 degrees, so every run exercises the localiser's convergence.
    """
    max_xy, max_yaw = INITIAL_POSE_MAX_ERROR
    distance = rng.uniform(0.1, max_xy)
    direction = rng.uniform(-math.pi, math.pi)
    yaw = rng.choice([-1.0, 1.0]) * rng.uniform(math.radians(3.0), max_yaw)
    return Pose2D(distance * math.cos(direction), distance * math.sin(direction), float(yaw))


@dataclass
class Metrics:
    """Ground-truth figures sampled every station clock period (METRICS ONLY)."""

    max_linear: float
    distance_m: float = 0.0
    moving_time_s: float = 0.0
    moving_speed_sum: float = 0.0
    corridor_speed_sum: float = 0.0
    corridor_samples: int = 0
    clearances: list[float] = field(default_factory=list)
    loc_errors: list[float] = field(default_factory=list)
    heading_errors: list[float] = field(default_factory=list)
    # the map pose's errors on the same samples (navigation's pose: `RobotStack.map_pose`)
    map_errors: list[float] = field(default_factory=list)
    losses: int = 0
    silent_failures: int = 0  # samples reported ok while > 0.3 m or 10 degrees off the truth
    degraded_s: float = 0.0  # simulated seconds spent in the degraded state
    worst: tuple[float, float, float] = (0.0, math.nan, math.nan)  # (error [m], true x, y)
    # Decomposition of the error (`map_echo`): every `echo_every`-th ok sample, the map's own
    # error there (perfect matcher vs truth) and the localiser's (estimate vs perfect matcher).
    echo: MapEcho | None = None
    echo_every: int = 5
    echo_errors: list[float] = field(default_factory=list)
    own_errors: list[float] = field(default_factory=list)
    own_heading_errors: list[float] = field(default_factory=list)
    own_worst: tuple[float, float, float] = (0.0, math.nan, math.nan)
    echo_unmatched: int = 0  # samples where the perfect matcher slid > ECHO_NEAR_M (left out)
    _echo_world: list[float] = field(default_factory=list)  # world-frame errors, same samples
    # NEES of the reported covariance against the truth, per ok sample: (x, y, yaw) and x, y.
    nees_pose: list[float] = field(default_factory=list)
    nees_position: list[float] = field(default_factory=list)
    _ok_samples: int = 0
    _last_pose: Pose2D | None = None
    _last_state: LocaliserState | None = None

    def sample(self, sim: Simulator, stack: RobotStack, dt: float) -> None:
        truth = sim.true_pose()
        if self._last_pose is not None:
            self.distance_m += truth.distance_to(self._last_pose)
        self._last_pose = truth
        linear, angular = sim.true_velocity()
        moving = abs(linear) > 0.02
        if moving:
            self.moving_time_s += dt
            self.moving_speed_sum += abs(linear) * dt
            self.clearances.append(sim.min_clearance())
            # "Open corridor": driving straight with room around the footprint.
            if abs(angular) < 0.15 and self.clearances[-1] > 0.6:
                self.corridor_speed_sum += abs(linear)
                self.corridor_samples += 1
        estimate = stack.pose
        state = stack.localisation_state
        if state != self._last_state and (
            state == LocaliserState.LOST
            or (
                state == LocaliserState.SEARCHING
                and self._last_state in (LocaliserState.OK, LocaliserState.DEGRADED)
            )
        ):
            self.losses += 1  # lost, or a global search started while localised (issue 16)
        self._last_state = state
        if estimate is not None and state == LocaliserState.OK:
            error = estimate.distance_to(truth)
            heading = abs(angle_diff(estimate.yaw, truth.yaw))
            self.loc_errors.append(error)
            self.heading_errors.append(heading)
            on_map = stack.map_pose or estimate
            self.map_errors.append(on_map.distance_to(truth))
            if error > SILENT_FAILURE_M or heading > SILENT_FAILURE_RAD:
                self.silent_failures += 1
            if error > self.worst[0]:
                self.worst = (error, truth.x, truth.y)
            e, cov = pose_error(estimate, truth), stack.pose_covariance
            self.nees_pose.append(nees(e, cov))
            self.nees_position.append(nees(e[:2], cov[:2, :2]))
            if self.echo is not None and self._ok_samples % self.echo_every == 0:
                self.echo.follow(stack.localiser.config.matcher)  # a learnt wall model
                # the split is the map pose's: the building pose departs from the map's fit
                self._sample_echo(on_map, truth)
            self._ok_samples += 1
        self.degraded_s += dt if state == LocaliserState.DEGRADED else 0.0

    def _sample_echo(self, estimate: Pose2D, truth: Pose2D) -> None:
        assert self.echo is not None
        ref = self.echo.reference(truth)
        if ref.distance_to(truth) > ECHO_NEAR_M:
            self.echo_unmatched += 1  # the reference match itself slid away: no reference
            return
        self.echo_errors.append(ref.distance_to(truth))
        own = estimate.distance_to(ref)
        self.own_errors.append(own)
        self._echo_world.append(estimate.distance_to(truth))
        self.own_heading_errors.append(abs(angle_diff(estimate.yaw, ref.yaw)))
        if own > self.own_worst[0]:
            self.own_worst = (own, truth.x, truth.y)

    def figures(self) -> dict[str, Any]:
        loc = np.asarray(self.loc_errors) if self.loc_errors else np.zeros(1)
        on_map = np.asarray(self.map_errors) if self.map_errors else np.zeros(1)
        heading = np.asarray(self.heading_errors) if self.heading_errors else np.zeros(1)
        clear = np.asarray(self.clearances) if self.clearances else np.full(1, math.nan)
        corridor = self.corridor_speed_sum / self.corridor_samples if self.corridor_samples else 0.0
        return {
            "distance_m": round(self.distance_m, 2),
            "localisation_losses": self.losses,
            "localisation_silent_failures": self.silent_failures,
            "localisation_degraded_s": round(self.degraded_s, 2),
            "mean_speed_mps": round(
                self.moving_speed_sum / self.moving_time_s if self.moving_time_s else 0.0, 4
            ),
            "corridor_speed_mps": round(corridor, 4),
            "corridor_speed_ratio": round(corridor / self.max_linear, 3),
            "min_clearance_m": round(float(clear.min()), 3),
            "max_clearance_m": round(float(clear.max()), 3),
            "mean_clearance_m": round(float(clear.mean()), 3),
            "loc_rms_m": round(float(np.sqrt(np.mean(loc**2))), 4),
            "loc_max_m": round(float(loc.max()), 4),
            "loc_heading_rms_deg": round(float(np.degrees(np.sqrt(np.mean(heading**2)))), 3),
            "loc_heading_max_deg": round(float(np.degrees(heading.max())), 3),
            "loc_silent_failures": self.silent_failures,
            # the map pose (navigation's) on the same samples: the map's offset not taken out
            "loc_map_pose_rms_m": round(float(np.sqrt(np.mean(on_map**2))), 4),
            "loc_map_pose_max_m": round(float(on_map.max()), 4),
            "loc_worst_at": [round(self.worst[1], 2), round(self.worst[2], 2)],
            **self._decomposition(),
            **self._covariance_figures(),
        }

    def _decomposition(self) -> dict[str, Any]:
        """The world-frame error of the *map pose* split (`map_echo`): ``loc_echo_*`` the map's
        own error where the robot was (a perfect matcher's), ``loc_own_*`` the localiser's map
        pose relative to that; on the same samples (``loc_echo_samples``) as ``loc_sub_rms_m``,
        the map pose's world-frame RMS on those samples. (The reported building pose departs
        from the map's fit on purpose: `map_offset`.)"""
        if not self.echo_errors:
            return {}
        echo = np.asarray(self.echo_errors)
        own = np.asarray(self.own_errors)
        world = np.asarray(self._echo_world)
        heading = np.asarray(self.own_heading_errors)

        def rms(a: np.ndarray) -> float:
            return round(float(np.sqrt(np.mean(a**2))), 4)

        return {
            "loc_echo_samples": int(echo.size),
            "loc_echo_unmatched": self.echo_unmatched,
            "loc_sub_rms_m": rms(world),
            "loc_echo_rms_m": rms(echo),
            "loc_echo_max_m": round(float(echo.max()), 4),
            "loc_own_rms_m": rms(own),
            "loc_own_max_m": round(float(own.max()), 4),
            "loc_own_heading_rms_deg": round(float(np.degrees(np.sqrt(np.mean(heading**2)))), 3),
            "loc_own_worst_at": [round(self.own_worst[1], 2), round(self.own_worst[2], 2)],
        }

    def _covariance_figures(self) -> dict[str, Any]:
        """Mean NEES per degree of freedom of the reported covariance against the truth (1 when
        honest, above when too confident), and the share of samples inside its 95 % region."""
        pose = np.asarray(self.nees_pose)
        pos = np.asarray(self.nees_position)
        pose, pos = pose[np.isfinite(pose)], pos[np.isfinite(pos)]
        if pose.size == 0:
            return {}
        return {
            "loc_nees_per_dof": round(float(pose.mean()) / 3.0, 3),
            "loc_nees_position_per_dof": round(float(pos.mean()) / 2.0, 3),
            "loc_inside_95": round(float(np.mean(pose <= CHI2_95_3DOF)), 3),
        }


class SimulatedSystem:
    """Simulator + robot stack + the station's supervisor on one simulated clock."""

    def __init__(
        self,
        options: ScenarioOptions,
        *,
        start_node: int | None = None,
        start_pose: Pose2D | None = None,
        supervisor_config: SupervisorConfig | None = None,
        stack_config: StackConfig | None = None,
        autonomy: bool = True,
        wall_clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        """``autonomy=False``: pure teleoperation. The station's routes still go to the robot, which
        judges progress on them as the operator drives (`goal_checker`), but its navigation
        stays paused (the ``pause_nav`` lock), so only the operator moves it."""
        self.options = options
        self.grid: OccupancyGrid = load_map(options.map_yaml)
        self.topo: TopologicalMap = load_topological_map(options.topo_yaml)
        self.route_planner = RoutePlanner(self.topo)
        if start_pose is None:
            start_pose = self.topo.node(
                self.topo.home_id if start_node is None else start_node
            ).pose
        self.start_pose = start_pose
        odometry = options.odometry
        if options.ideal_world and odometry == "realistic":
            odometry = "calibrated"
        sim_config = SimConfig(
            internal_dt=SIM_DT,
            start_pose=start_pose,
            n_people=options.people,
            odometry=OdometryErrorModel.named(odometry),
        )
        world_grid = self.grid
        # What the person setting the initial pose gets wrong (ideal world: nothing).
        self.initial_pose_error = Pose2D(0.0, 0.0, 0.0)
        self.world_spec: SimWorldSpec | None = None
        if not options.ideal_world:
            world_seed, pose_seed = np.random.SeedSequence([options.seed, 12]).spawn(2)
            self.world_spec = build_sim_world(
                self.grid,
                np.random.default_rng(world_seed),
                plan_yaml=plan_beside(Path(options.map_yaml)),
                topo=self.topo,
                keep_clear=[(start_pose.x, start_pose.y)],
            )
            world_grid = self.world_spec.grid
            sim_config = msgspec.structs.replace(
                sim_config,
                laser=LaserConfig.realistic(),
                obstacles=tuple(
                    RectObstacle(i.center_x, i.center_y, i.size_x, i.size_y, i.yaw)
                    for i in self.world_spec.items
                ),
                glass=tuple((g.x0, g.y0, g.x1, g.y1) for g in self.world_spec.glass),
            )
            self.initial_pose_error = person_set_pose_error(np.random.default_rng(pose_seed))
        self.sim = Simulator(world_grid, sim_config, rng_seed=options.seed)
        if stack_config is None:  # the daemon's wall model, the same as on the robot
            stack_config = StackConfig(localiser=daemon_localiser_config())
        rates = stack_config.rates
        self.backend = SimBackend(
            self.sim, scan_rate_hz=max(rates.localiser_hz, rates.controller_hz), camera_rate_hz=0
        )
        self.stack = RobotStack(self.grid, self.backend, stack_config)
        self.supervisor = Supervisor(self.topo, self.route_planner, supervisor_config)
        self.metrics = Metrics(stack_config.planner.max_linear_speed)
        if self.world_spec is not None:  # world = map: the map's own error is zero
            self.metrics.echo = MapEcho(
                self.grid,
                self.sim.world,
                self.sim.laser.config,
                stack_config.localiser,
                stack_config.laser_mount,
            )
        self.autonomy = autonomy
        if not autonomy:
            self.stack.on_lock("pause_nav", True, 0.0)
        self.now = 0.0
        self.events: list[tuple[float, Event]] = []
        self.hooks: list[Callable[[SimulatedSystem, Event], None]] = []
        # (when [s], action): what a person at the tablet does a little later.
        self.pending: list[tuple[float, Callable[[], list[Event]]]] = []
        self._route_ids = 0
        self._next_clock = 0.0
        self._wall_clock = wall_clock
        jit.warm_up()  # compiling (a machine's first run) is not the robot's work: out of RTFs
        self._wall_start = wall_clock()
        self._cpu_start = time.process_time()
        self._metrics_wall_s = 0.0  # [s] spent in `Metrics.sample` (excluded from the RTFs)
        self._metrics_cpu_s = 0.0
        self._robot_route_seen: tuple[int, str] | None = None

    # -- the station's side ------------------------------------------------------------------

    def localise(self) -> None:
        """The operator sets the initial pose where the robot stands (thesis: required).

        A person clicking the pose on the map is off by ``initial_pose_error`` (realistic world).
        """
        self.stack.set_initial_pose(self.start_pose.compose(self.initial_pose_error), self.now)

    def relocalise(self) -> None:
        """The operator presses the station's "Relocalise" (`StationController.relocalise`):
        the link's ``Relocalise`` reaches the daemon, which calls `RobotStack.relocalise`, as
        here. A command: the robot searches the whole map and may turn to look around."""
        self.stack.relocalise(self.now)

    def _route_message(self, started: RouteStarted) -> RouteMsg:
        self._route_ids += 1
        cfg = self.supervisor.config
        waypoints = tuple((w.x, w.y, w.yaw) for w in started.waypoints)
        ids = started.node_ids
        node_ids = tuple(i for i in ids if i is not None) if None not in ids else ()
        return RouteMsg(
            self._route_ids,
            waypoints,
            node_ids,
            approach_tolerance=cfg.approach_tolerance,
            goal_tolerance=cfg.goal_tolerance,
            yaw_tolerance=cfg.yaw_tolerance,
        )

    def apply(self, events: list[Event]) -> None:
        """Carry supervisor events to the robot as the station does over the link."""
        for event in events:
            self.events.append((self.now, event))
            if isinstance(event, RouteStarted):
                self.stack.set_route(self._route_message(event), self.now)
            elif isinstance(event, RouteCancelled):
                self.stack.cancel_route(self.now, event.reason)
            elif isinstance(event, PauseNavigation) and self.autonomy:
                self.stack.on_lock("pause_nav", event.paused, self.now)
            for hook in self.hooks:
                hook(self, event)

    def station_view(self) -> tuple[Pose2D | None, RobotCondition]:
        """What the station's supervisor is given, as the station takes it from the robot's
        pose message (`RobotState.localised_pose`, `SupervisorEvents.condition`): the pose only
        while ok or degraded; and whether the robot looks for a pose it had (lost, searching
        or turning with a pose), connected (one loop here) and not stopped."""
        stack = self.stack
        state, pose = stack.reported_localisation, stack.pose
        localised = pose if state in ("ok", "degraded") else None
        finding = pose is not None and state in ("lost", "searching", "turning")
        with stack.motion_lock:
            stopped = any(lock.topic == STOP_TOPIC for lock in stack.mux.active_locks(self.now))
        return localised, RobotCondition(True, stopped, finding)

    def _station_clock(self) -> None:
        due = [item for item in self.pending if item[0] <= self.now + 1e-9]
        for item in due:
            self.pending.remove(item)
            self.apply(item[1]())
        route = self.stack.route
        if route is not None and route.route_id == self._route_ids:
            # The station mirrors the robot's progress (route_progress): no goal logic of its own.
            self.apply(self.supervisor.robot_progress(route.index))
        if route is not None and route.finished:
            key = (route.route_id, route.state)
            if key != self._robot_route_seen:
                self._robot_route_seen = key
                if route.state == "succeeded":
                    self.apply(self.supervisor.robot_route_succeeded(self.now))
                elif route.state == "aborted":
                    self.apply(self.supervisor.robot_route_aborted(route.reason))
        self.apply(self.supervisor.update(self.now, *self.station_view()))
        wall, cpu = self._wall_clock(), time.process_time()
        self.metrics.sample(self.sim, self.stack, CLOCK_DT)
        # The metrics' ground-truth matching is not the robot's work: out of the RTFs.
        self._metrics_wall_s += self._wall_clock() - wall
        self._metrics_cpu_s += time.process_time() - cpu

    # -- the loop -------------------------------------------------------------------------------

    def step(self) -> None:
        """One daemon loop pass (and the station's clock() when due)."""
        self.now = round(self.now + STACK_DT, 9)
        self.backend.advance(self.now)
        self.stack.step(self.now)
        if self.now + 1e-9 >= self._next_clock:
            self._next_clock += CLOCK_DT
            self._station_clock()
        if self.options.recorder is not None:
            self.options.recorder.sample(self)

    def run_until(self, done: Callable[[], bool], max_time: float | None = None) -> bool:
        """Step until ``done()`` or ``max_time`` [s] of simulated time; True if done."""
        limit = self.now + (max_time if max_time is not None else self.options.max_sim_time)
        while self.now < limit:
            self.step()
            if done():
                return True
        return False

    def realtime_factor(self) -> float:
        wall = self._wall_clock() - self._wall_start - self._metrics_wall_s
        return self.now / wall if wall > 0 else math.inf

    def cpu_realtime_factor(self) -> float:
        """Simulated seconds per CPU second of this process: the real-time factor a quiet
        machine would show, whatever else shares the cores (measurement only)."""
        cpu = time.process_time() - self._cpu_start - self._metrics_cpu_s
        return self.now / cpu if cpu > 0 else math.inf

    def of(self, kind: type) -> list[tuple[float, Any]]:
        return [(t, e) for t, e in self.events if isinstance(e, kind)]


def auto_resume_tour(dwell_s: float) -> Callable[[SimulatedSystem, Event], None]:
    """A visitor at each tour stop who reads the room's information and taps Resume."""

    def hook(system: SimulatedSystem, event: Event) -> None:
        if isinstance(event, TourStopReached):
            resume_at = system.now + dwell_s
            system.pending.append((resume_at, system.supervisor.tour_resume))

    return hook


def auto_answer_requests(
    dwell_s: float, accept: bool = True
) -> Callable[[SimulatedSystem, Event], None]:
    """Whoever is in the room reads the request on the tablet and accepts (or declines) it."""

    def hook(system: SimulatedSystem, event: Event) -> None:
        if isinstance(event, RequestShown):
            system.pending.append(
                (system.now + dwell_s, lambda: system.supervisor.request_response(accept))
            )

    return hook


# -- generic helpers for scripted scenarios (odometry, mission, latency) ----------------------


@dataclass(frozen=True)
class StraightSegment:
    """A straight, collision-free stretch between two topological nodes (map frame)."""

    start: tuple[float, float]  # [m]
    end: tuple[float, float]  # [m]
    clearance: float  # [m] smallest free-space distance along it
    nodes: tuple[int, int]

    @property
    def length(self) -> float:
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    @property
    def heading(self) -> float:
        return math.atan2(self.end[1] - self.start[1], self.end[0] - self.start[0])

    def distance_to(self, x: float, y: float) -> float:
        """Distance [m] from (x, y) to the segment."""
        ax, ay = self.start
        dx, dy = self.end[0] - ax, self.end[1] - ay
        t = max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / max(self.length**2, 1e-12)))
        return math.hypot(x - ax - t * dx, y - ay - t * dy)


def free_space_distance(grid: OccupancyGrid) -> np.ndarray:
    """Distance [m] from each cell to the nearest blocked (occupied/unknown) cell."""
    from scipy import ndimage

    return np.asarray(
        ndimage.distance_transform_edt(~grid.blocked(), sampling=grid.resolution),
        dtype=np.float64,
    )


def clearance_along(
    distance: np.ndarray, grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float]
) -> float:
    """The smallest free-space distance [m] on the line a-b (sampled every half cell); 0 when
    the line leaves the map."""
    n = max(2, int(math.hypot(b[0] - a[0], b[1] - a[1]) / (0.5 * grid.resolution)) + 1)
    rows, cols = grid.world_to_cell(np.linspace(a[0], b[0], n), np.linspace(a[1], b[1], n))
    if not bool(np.all(grid.in_bounds(rows, cols))):
        return 0.0
    return float(distance[rows, cols].min())


def straight_segments(
    grid: OccupancyGrid, topo: TopologicalMap, min_clearance: float = 0.7
) -> list[StraightSegment]:
    """Every straight node-to-node segment whose free-space distance stays >= ``min_clearance``
    (> 0), longest first (ties by node ids, so the choice is deterministic)."""
    distance = free_space_distance(grid)
    found: list[StraightSegment] = []
    nodes = topo.nodes
    for i, a in enumerate(nodes):
        for b in nodes[i + 1 :]:
            if a.pose.distance_to(b.pose) < 1.0:
                continue
            ends = (a.pose.x, a.pose.y), (b.pose.x, b.pose.y)
            clearance = clearance_along(distance, grid, *ends)
            if clearance >= min_clearance:
                found.append(StraightSegment(*ends, clearance, (a.id, b.id)))
    found.sort(key=lambda s: (-round(s.length, 6), s.nodes))
    return found


def drive_to_pose(system: SimulatedSystem, pose: Pose2D, max_time: float = 600.0) -> bool:
    """Let the supervisor drive the robot autonomously to ``pose``; True if it got there."""
    from interbot_core.supervisor import GoToPose

    before = len(system.of(TaskFinished))
    system.apply(system.supervisor.submit(GoToPose(pose)))
    done = system.run_until(lambda: len(system.of(TaskFinished)) > before, max_time)
    finished = system.of(TaskFinished)
    return done and bool(finished[-1][1].ok)


def run_ticks(
    system: SimulatedSystem,
    tick: Callable[[float], bool],
    max_time: float,
    period: float = CLOCK_DT,
    on_step: Callable[[float], None] | None = None,
) -> bool:
    """Step the system, calling ``tick(now)`` every ``period`` [s] (a controller's loop) until it
    returns True or ``max_time`` [s] passes; ``on_step(now)`` runs after every daemon step."""
    limit = system.now + max_time
    next_tick = system.now
    while system.now < limit:
        if system.now + 1e-9 >= next_tick:
            next_tick += period
            if tick(system.now):
                return True
        system.step()
        if on_step is not None:
            on_step(system.now)
    return False
