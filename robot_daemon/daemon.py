"""The robot daemon process: `RobotStack` on a backend, linked to stations over zenoh.

One thread runs everything that decides (thesis Fig. 4.5 in one loop): it takes the commands
the zenoh callbacks queued (`RobotLink.poll_commands`), steps the stack, and publishes state at
fixed rates. A second, the command thread (issue 14), takes only the motion commands
(`interbot_link.robot.MOTION_TOPICS`: teleoperation, pause, stop, stop release) and applies them
to the multiplexer and the motors the moment they arrive, and publishes the new ``mux``
output: a command never waits for a pass's localiser, planner or simulator work. The command
thread and the link's zenoh callback thread run at real-time priority where the OS allows it
(`interbot_link.command_priority`): the bench's per-hop time stamps showed commands waiting for
a busy core, a scheduler tick at a time, behind the simulator, the localiser or other programs.
So do zenoh's own network threads, which read the commands and send the mux output (the loop
looks for them every second: zenoh starts them as links come up). The loop and the command
thread meet only under `RobotStack.motion_lock`, so the e-stop latch, the stale-input zero and
the collision monitor apply to every output, whichever thread computed it. Time is the
monotonic clock, or simulated time running ``realtime_factor`` times as fast with the simulator. The systemd watchdog is fed from this loop, so a stuck loop gets the
service restarted. SIGTERM stops it cleanly: motors to zero, link closed, zenoh session closed.
"""

from __future__ import annotations

import logging
import secrets
import socket
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid, load_map
from interbot_core.route_planner import RoutePlanner, RoutePlanningError
from interbot_core.topics import (
    MAX_NOTICES,
    MAX_POSE_VARIANCE,
    MAX_SAFETY_DISTANCE,
    AssistMsg,
    Battery,
    ConfigMsg,
    GoalMsg,
    ImageMsg,
    InitialPose,
    Lock,
    MuxMsg,
    Odom,
    PlanMsg,
    PoseMsg,
    RangeEncoding,
    Relocalise,
    RouteCancel,
    RouteMsg,
    RouteProgress,
    SafetyMsg,
    StandingNotices,
    Status,
    StopRelease,
    Topic,
    TopicError,
    Twist,
)
from interbot_core.topological_map import TopologicalMap, TopologicalMapError, load_topological_map
from interbot_core.velocity_mux import MuxError, MuxOutput, load_mux_config
from interbot_link import Command, RobotLink, open_session
from interbot_link.command_priority import (
    SCAN_PERIOD_S,
    NamedThreadRaiser,
    PriorityOutcome,
    raise_current_thread,
)
from robot_daemon import jit
from robot_daemon.backend import RobotBackend
from robot_daemon.config import DaemonConfig
from robot_daemon.device_health import DeviceHealth
from robot_daemon.link_security import link_security
from robot_daemon.localisation.localiser import LocaliserConfig
from robot_daemon.localisation.look_around import LookAroundConfig
from robot_daemon.localisation.relocalisation import RelocalisationConfig
from robot_daemon.localisation.relocaliser import RelocaliserConfig
from robot_daemon.localisation.wall_model import wall_model_setting
from robot_daemon.planning.path_report import plan_message
from robot_daemon.safety.motion_guard import load_safety_config
from robot_daemon.sim.odometry_model import OdometryErrorModel
from robot_daemon.sim.simulator import SimConfig, Simulator
from robot_daemon.sim_backend import SimBackend
from robot_daemon.stack import (
    STOP_TOPIC,
    Periodic,
    RobotStack,
    RouteState,
    StackConfig,
    StackError,
)
from robot_daemon.systemd_notify import SystemdNotifier

logger = logging.getLogger(__name__)

LOOP_PERIOD = 0.02  # [s] wall time between passes of the control loop (50 Hz)
SLOW_PASS = 0.1  # [s] a pass longer than this is logged: commands waited that long
SLOW_PASS_LOG_PERIOD = 10.0  # [s] wall time between two such log lines
MAP_REPUBLISH_PERIOD = 30.0  # [s]
SAFETY_HZ = 10.0  # [Hz] collision monitor report to the station (topic safety)
COMMAND_WAIT = 0.1  # [s] the command thread re-checks for a stop this often when idle


@dataclass(frozen=True)
class DaemonOptions:
    """Run-time choices that are not part of the robot's configuration."""

    auto_localise: bool = False  # set the initial pose at the sim's start (demo convenience)
    start_node: int | None = None  # sim: start at this topological node (default: home)
    relocalise: bool = True  # search the map by itself at start-up, when lost, when kidnapped
    record_dir: Path | None = None  # --record DIR: MCAP recording (robot_daemon/recording)
    foxglove: str | None = None  # --foxglove [HOST:]PORT: live Foxglove view


def build_sim_backend(
    config: DaemonConfig, grid: OccupancyGrid, start: Pose2D, scan_rate_hz: float
) -> SimBackend:
    sim_config = SimConfig(
        start_pose=start,
        n_people=config.sim.people,
        odometry=OdometryErrorModel.named(config.sim.odometry),
    )
    simulator = Simulator(grid, sim_config, rng_seed=config.sim.seed)
    return SimBackend(simulator, scan_rate_hz=scan_rate_hz, camera_rate_hz=config.rates.image_hz)


def build_hardware_backend(config: DaemonConfig) -> RobotBackend:
    """The real devices (Hokuyo, RoboteQ, camera) from robot.yaml's ``hardware:`` section.

    Their drivers stamp data with ``time.monotonic()``, the daemon's clock on a real robot.
    """
    from robot_daemon.hardware.config import HardwareConfig
    from robot_daemon.hardware.hardware_backend import HardwareBackend

    # a HardwareConfigError is a ConfigError
    return HardwareBackend(HardwareConfig.from_mapping(config.hardware, config.source))


class Daemon:
    """Everything the daemon runs, built from a validated `DaemonConfig`."""

    def __init__(
        self,
        config: DaemonConfig,
        options: DaemonOptions | None = None,
        *,
        backend: RobotBackend | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.config = config
        self.options = options = options or DaemonOptions()
        self._clock = clock
        self.grid = load_map(config.map_yaml)
        # A bad safety (or hardware) section is a ConfigError: the daemon does not start.
        motion_guard = load_safety_config(config.safety_yaml)
        self.topo: TopologicalMap | None = None
        self.route_planner: RoutePlanner | None = None
        if config.topo_yaml.exists():
            # A topological map that is there but wrong (dangling arcs, duplicate ids) is refused:
            # starting without it would hide the error until a goal is refused.
            self.topo = load_topological_map(config.topo_yaml)
            self.route_planner = RoutePlanner(self.topo)
        else:
            logger.warning("no topological map %s: goals by node id are refused", config.topo_yaml)
        rates = config.rates
        self.start_pose = Pose2D(0.0, 0.0, 0.0)
        if self.topo is not None:
            node = self.topo.home_id if options.start_node is None else options.start_node
            self.start_pose = self.topo.node(node).pose
        if backend is None:
            if config.backend == "hardware":
                backend = build_hardware_backend(config)
            else:
                backend = build_sim_backend(
                    config, self.grid, self.start_pose, max(rates.localiser_hz, rates.scan_hz)
                )
        self.backend = backend
        # the map's wall model, learnt (or fixed) the same way in sim and on hardware
        matcher, wall_model = wall_model_setting(config.localiser.map_surface)
        stack_config = StackConfig(
            rates=rates,
            mux=load_mux_config(config.mux_yaml),
            motion_guard=motion_guard,
            localiser=LocaliserConfig(matcher=matcher, wall_model=wall_model),
            relocalisation=RelocalisationConfig(
                relocaliser=RelocaliserConfig(help_after_s=config.localiser.help_after_s),
                on_unset=options.relocalise,
                on_lost=options.relocalise,
                background=options.relocalise,
            ),
            look_around=LookAroundConfig(
                enabled=options.relocalise and config.localiser.look_around
            ),
        )
        self.stack = RobotStack(self.grid, backend, stack_config)
        # Global searches (0.1-1 s) run on a worker thread, never stalling the 50 Hz loop.
        self._search_thread = ThreadPoolExecutor(1, thread_name_prefix="global-search")
        if options.relocalise:
            self.stack.relocalisation.run_searches_in(self._search_thread)
        # What is published when: robot.yaml's rates by name ("pose", "scan", ...), the map, safety.
        due_hz = {key.removesuffix("_hz"): v for key, v in msgspec.structs.asdict(rates).items()}
        due_hz |= {"map": 1.0 / MAP_REPUBLISH_PERIOD, "safety": SAFETY_HZ}
        self._due = {name: Periodic(hz) for name, hz in due_hz.items()}
        self._progress_key: tuple[int, int, str] | None = None
        self._plan_key: tuple[int, tuple[tuple[float, float], ...]] | None = None
        self._health = DeviceHealth()  # faults and contacts, said once (alerts at the station)
        self._notices: list[Status] = []  # standing status lines, for stations that join later
        self._time0 = clock()
        self.now = 0.0  # [s] daemon time: simulated in sim mode
        self.component_errors = 0  # errors caught in the loop (each reported, robot stopped)
        self.slow_passes = 0  # passes longer than SLOW_PASS (commands waited)
        self.command_priority: PriorityOutcome | None = None  # the command thread's scheduling
        # zenoh's network threads carry the commands in and the mux output out (issue 14).
        self.network_threads = NamedThreadRaiser("the daemon's zenoh threads")
        self._slow_logged = -SLOW_PASS_LOG_PERIOD
        if options.auto_localise:
            self.stack.set_initial_pose(self.start_pose, 0.0)
        if config.start_latched:
            # After a (re)start nothing moves until a station that sees the robot releases the
            # stop (it re-asserts its operator's stop, or releases it, on every connection).
            self.stack.on_lock(STOP_TOPIC, True, 0.0)
            self.stack.on_lock(STOP_TOPIC, False, 0.0)  # latched, released only by stop_release

    # -- time ------------------------------------------------------------------------------

    def _advance_time(self) -> float:
        elapsed = self._clock() - self._time0
        factor = self.config.sim.realtime_factor if isinstance(self.backend, SimBackend) else 1.0
        # Never step more than 0.2 s of robot time at once (a debugger pause, a slow machine).
        self.now = max(self.now, min(elapsed * factor, self.now + 0.2))
        if isinstance(self.backend, SimBackend):
            self.backend.advance(self.now)
        return self.now

    # -- commands ----------------------------------------------------------------------------

    def handle(self, command: Command, link: RobotLink | None = None) -> None:
        """Apply one station command; a refusal is logged and reported on ``status``."""
        now, msg, topic = self.now, command.message, command.topic
        try:
            if isinstance(msg, Twist):
                self.stack.on_twist(topic.value, msg.linear, msg.angular, now)
            elif isinstance(msg, Lock):
                self.stack.on_lock(topic.value, msg.engaged, now)
            elif isinstance(msg, StopRelease):
                self.stack.release_stop(now, msg.operator)
            elif isinstance(msg, RouteMsg):
                self.stack.set_route(msg, now)
            elif isinstance(msg, RouteCancel):
                self.stack.cancel_route(now, msg.reason or "cancelled by the station")
            elif isinstance(msg, InitialPose):
                self.stack.set_initial_pose(Pose2D(msg.x, msg.y, msg.yaw), now, msg.verify)
            elif isinstance(msg, Relocalise):
                self.stack.relocalise(now)
            elif isinstance(msg, ConfigMsg):
                self.stack.reconfigure(dict(msg.params), now)
            elif isinstance(msg, GoalMsg):
                self.stack.set_route(self._route_for_goal(msg), now)
            elif isinstance(msg, AssistMsg):
                self.stack.set_teleop_assist(msg.input, msg.enabled, now)
        except (StackError, MuxError, RoutePlanningError, TopologicalMapError, TopicError) as exc:
            logger.warning("refused %s command: %s", topic.value, exc)
            if link is not None:
                link.publish(
                    Topic.STATUS, Status("error", f"refused {topic.value}: {exc}", stamp=now)
                )

    def _route_for_goal(self, goal: GoalMsg) -> RouteMsg:
        """A route for a single goal: through the topological map to a node, or straight.

        Its id is random (63 bits), so it never repeats one from before a restart.
        """
        route_id = secrets.randbits(63)
        target = Pose2D(goal.x, goal.y, goal.yaw)
        pose = self.stack.map_pose  # planned on the map, as navigation
        if goal.node_id is None or self.route_planner is None or pose is None:
            return RouteMsg(route_id, ((target.x, target.y, target.yaw),))
        route = self.route_planner.plan(pose, goal.node_id)
        waypoints = tuple((w.x, w.y, w.yaw) for w in route.waypoints)
        return RouteMsg(route_id, waypoints, tuple(route.node_ids))

    # -- publishing -----------------------------------------------------------------------------

    def publish(self, link: RobotLink) -> None:
        now, stack, due = self.now, self.stack, self._due
        if due["pose"](now):
            publish_state(stack, now, link.publish)
        if due["scan"](now) and stack.last_scan is not None:
            link.publish_scan(stack.last_scan, RangeEncoding.UINT16_MM)
        if due["image"](now) and stack.last_jpeg is not None and link.subscribed(Topic.IMAGE):
            jpeg = stack.last_jpeg
            link.publish(Topic.IMAGE, ImageMsg(now, *_jpeg_size(jpeg), jpeg))
        if due["battery"](now) and stack.last_battery is not None:
            b = stack.last_battery
            link.publish(Topic.BATTERY, Battery(b.voltage, b.current, b.state_of_charge, now))
        if due["map"](now):
            link.publish(Topic.MAP, stack.localiser.updated_grid())
        if due["safety"](now):
            link.publish(Topic.SAFETY, safety_message(stack, now))
        status_due = due["status"](now)
        self._publish_route(link, force=status_due)
        if status_due:
            self._publish_plan(link, now)
            for level, text in self._health.changes(self.backend.device_status()):
                logger.log(logging.ERROR if level == "error" else logging.INFO, "%s", text)
                link.publish(Topic.STATUS, Status(level, text, stamp=now))
        for event in stack.drain_events():
            status = Status(event.level, event.text, stamp=event.stamp)
            link.publish(Topic.STATUS, status)
            if event.standing:
                self._notices = [*self._notices, status][-MAX_NOTICES:]
                link.publish(Topic.NOTICES, StandingNotices(tuple(self._notices)))

    def _publish_plan(self, link: RobotLink, now: float) -> None:
        """The navigator's path, when it changed (the snapshot keeps it for late stations)."""
        plan = current_plan(self.stack, now)
        key = (plan.route_id, plan.points)
        if key != self._plan_key:
            self._plan_key = key
            link.publish(Topic.PLAN, plan)

    def _publish_route(self, link: RobotLink, force: bool) -> None:
        route = self.stack.route
        if route is None:
            # Say "no route" too: a station that reconnects learns that the robot has none.
            if force or self._progress_key is None:
                self._progress_key = (0, 0, "idle")
                link.publish(Topic.ROUTE_PROGRESS, RouteProgress(0, 0, False, "idle", "", self.now))
            return
        key = (route.route_id, route.index, route.state)
        if key != self._progress_key or force:
            self._progress_key = key
            reason = route.reason or (self.stack.suspended_reason or "")
            link.publish(Topic.ROUTE_PROGRESS, route_progress(route, reason, self.now))

    # -- the loop ------------------------------------------------------------------------------

    def run(self, link: RobotLink, stop: threading.Event, notifier: SystemdNotifier) -> None:
        """Run until ``stop`` is set."""
        # Compile (first run on this machine) or load the kernels before the loop needs them.
        took = jit.warm_up()
        logger.info("kernels ready in %.2f s (%s)", took, "numba" if jit.ENABLED else "Python")
        link.publish(Topic.MAP, self.grid)
        done = threading.Event()  # the command thread stops with the loop, however it ends
        commands = threading.Thread(
            target=self._command_loop, args=(link, done), name="motion-commands", daemon=True
        )
        commands.start()
        notifier.ready(f"robot {self.config.robot_id} serving")
        logger.info("daemon ready: %s", self.config.summary())
        next_tick = next_scan = time.monotonic()
        try:
            while not stop.is_set():
                if time.monotonic() >= next_scan:
                    next_scan = time.monotonic() + SCAN_PERIOD_S
                    self._raise_network_threads()
                next_tick = self._pass(link, notifier, next_tick)
                # Sleep until the next pass, or until a (non-motion) command arrives.
                link.wait_commands(max(0.0, next_tick - time.monotonic()), motion=False)
        finally:
            done.set()
            commands.join(2.0)
            # Every way out (stop, exception, KeyboardInterrupt) leaves the motors at zero.
            self._motors_to_zero()
            self.backend.close()
            self._search_thread.shutdown(wait=False, cancel_futures=True)
            notifier.stopping()

    def _command_loop(self, link: RobotLink, done: threading.Event) -> None:
        """The command thread: motion commands to the multiplexer and motors as they arrive.

        At real-time priority where the OS allows it (`interbot_link.command_priority`): it
        preempts the simulator, the localiser and the planner the moment a command arrives."""
        outcome = raise_current_thread("the daemon's command thread")
        self.command_priority = outcome
        logger.log(logging.INFO if outcome.realtime else logging.WARNING, "%s", outcome.text)
        while not done.is_set():
            if link.wait_commands(COMMAND_WAIT, motion=True):
                self.apply_motion(link, link.poll_commands(motion=True))

    def _raise_network_threads(self) -> None:
        """zenoh's network threads to the command threads' priority (as zenoh starts them);
        the first outcome is logged, a refusal as a warning."""
        try:
            outcome = self.network_threads.scan()
        except Exception:  # a priority is never worth the loop: say it and drive on
            logger.exception("could not look for zenoh's network threads")
            return
        if outcome is not None:
            logger.log(logging.INFO if outcome.realtime else logging.WARNING, "%s", outcome.text)

    def apply_motion(self, link: RobotLink, commands: list[Command]) -> None:
        """Apply teleoperation / pause / stop commands and send the new output to the motors.

        Stamped with the loop's latest time (at most one pass old): the command thread never
        advances the simulator. The output is computed and published under the motion lock, so
        ``mux`` samples leave in the order the outputs were made.
        """
        if not commands:
            return
        try:
            with self.stack.motion_lock:
                for command in commands:
                    self.handle(command, link)
                now = self.now
                out = self.stack.apply_output(now)
                link.publish(Topic.MUX, mux_message(out, now))
        except Exception as exc:  # report and stop, as the loop does (its route is its own)
            self._on_component_error(exc, link, abort_route=False)

    def _pass(self, link: RobotLink, notifier: SystemdNotifier, next_tick: float) -> float:
        """One pass of the loop; a component's error is reported and stops the robot."""
        try:
            self._advance_time()
            commands = link.poll_commands(motion=False)
            for command in commands:
                self.handle(command, link)
            if time.monotonic() >= next_tick:
                started = time.monotonic()
                self.stack.step(self.now)
                stepped = time.monotonic()
                self.publish(link)
                notifier.watchdog(time.monotonic())
                self._check_pass_time(started, stepped, time.monotonic())
                next_tick += LOOP_PERIOD
                if next_tick < time.monotonic():
                    next_tick = time.monotonic()  # overran: do not try to catch up
        except Exception as exc:  # any component: report, stop, carry on
            self._on_component_error(exc, link)
            next_tick = time.monotonic() + LOOP_PERIOD
        return next_tick

    def _check_pass_time(self, started: float, stepped: float, done: float) -> None:
        """Count and log (at most every 10 s) a pass that held commands back too long."""
        if done - started <= SLOW_PASS:
            return
        self.slow_passes += 1
        if done - self._slow_logged >= SLOW_PASS_LOG_PERIOD:
            self._slow_logged = done
            logger.warning(
                "slow control loop pass: %.0f ms (step %.0f ms, publish %.0f ms; %d so far)",
                (done - started) * 1000,
                (stepped - started) * 1000,
                (done - stepped) * 1000,
                self.slow_passes,
            )

    def _on_component_error(
        self, exc: Exception, link: RobotLink, abort_route: bool = True
    ) -> None:
        """Zero the motors, give up the route (the station is told) and report the error.

        The command thread leaves the route to the loop thread that drives it
        (``abort_route=False``): the robot stops, and the station hears why."""
        self.component_errors += 1
        logger.exception("component error in the control loop; robot stopped")
        self._motors_to_zero()
        text = f"internal error, robot stopped: {type(exc).__name__}: {exc}"[:900]
        try:
            if abort_route:
                self.stack.abort_route(self.now, text)
            link.publish(Topic.STATUS, Status("error", text, stamp=self.now))
        except Exception:  # reporting must not take the loop down
            logger.exception("could not report the component error")

    def _motors_to_zero(self) -> None:
        try:
            with self.stack.motion_lock:
                self.backend.set_cmd_vel(0.0, 0.0, self.now)
        except Exception:  # the backend itself is broken: log and go on
            logger.exception("could not set the motors to zero")


def publish_state(stack: RobotStack, now: float, publish: Callable[[Topic, object], None]) -> None:
    """The pose, odometry, cmd_vel and mux at the pose rate (`ScenarioRecorder` records them)."""
    pose, estimate = stack.pose, stack.last_estimate
    confidence = estimate.confidence if estimate is not None else 0.0
    cov: tuple[float, ...] = ()
    if pose is None:  # no pose yet: unset, or a start-up search (PoseMsg.known)
        pose, confidence = Pose2D(0.0, 0.0, 0.0), 0.0
    else:
        clipped = np.clip(stack.pose_covariance, -MAX_POSE_VARIANCE, MAX_POSE_VARIANCE)
        cov = tuple(clipped.ravel().tolist())
    state = stack.reported_localisation
    publish(Topic.POSE, PoseMsg(pose.x, pose.y, pose.yaw, now, state, confidence, cov))
    odom = stack.last_odometry
    if odom is not None:
        p = odom.pose
        publish(Topic.ODOM, Odom(p.x, p.y, p.yaw, odom.linear, odom.angular, now))
    with stack.motion_lock:  # in order with the command thread's mux samples
        out = stack.last_output
        publish(Topic.CMD_VEL, Twist(out.linear, out.angular, now))
        publish(Topic.MUX, mux_message(out, now))


def current_plan(stack: RobotStack, now: float) -> PlanMsg:
    """The navigator's path on the route in progress (none: route 0, no points)."""
    route = stack.route
    route_id = route.route_id if route is not None and not route.finished else 0
    return plan_message(route_id, stack.navigator.path if route_id else [], now)


def mux_message(out: MuxOutput, now: float) -> MuxMsg:
    """The multiplexer's output as the ``mux`` topic carries it."""
    return MuxMsg(out.source, out.reason, out.active_locks, out.linear, out.angular, now)


def route_progress(route: RouteState, reason: str, now: float) -> RouteProgress:
    """The robot's progress on its route as the ``route_progress`` topic carries it."""
    succeeded = route.state == "succeeded"
    return RouteProgress(route.route_id, route.index, succeeded, route.state, reason, now)


def safety_message(stack: RobotStack, now: float) -> SafetyMsg:
    """The motion guard's report as the ``safety`` topic carries it (no inf on the wire)."""
    with stack.motion_lock:
        r = stack.guard.report()
    cap = MAX_SAFETY_DISTANCE
    return SafetyMsg(
        r.zone,
        r.zone_name,
        min(r.distance, cap),
        min(r.time_to_contact, cap),
        max(0.0, min(1.0, r.scale)),
        r.assisted,
        r.assist_mode,
        now,
    )


def _jpeg_size(jpeg: bytes) -> tuple[int, int]:
    """(width, height) from a JPEG's SOF marker, without decoding it."""
    i = 2
    while i + 9 < len(jpeg):
        if jpeg[i] != 0xFF:
            break
        marker, length = jpeg[i + 1], int.from_bytes(jpeg[i + 2 : i + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            height = int.from_bytes(jpeg[i + 5 : i + 7], "big")
            width = int.from_bytes(jpeg[i + 7 : i + 9], "big")
            return width, height
        i += 2 + length
    return 0, 0


def _wait_for_router(connect: tuple[str, ...], stop: threading.Event) -> bool:
    """A zenoh client cannot open without its router: probe it until it answers (0.2 s doubling
    to 2 s) or ``stop``; True when reachable. The robot stays still meanwhile (no session, no
    commands; the motors' own watchdog holds them)."""
    delay = 0.2
    while not stop.is_set():
        for endpoint in connect:
            host, _, port = endpoint.split("/", 1)[-1].rpartition(":")
            try:
                with socket.create_connection((host.strip("[]"), int(port)), timeout=1.0):
                    return True
            except OSError:
                continue
        logger.warning("zenoh router not reachable at %s; retrying in %.1f s", connect, delay)
        stop.wait(delay)
        delay = min(2.0, delay * 2)
    return False


def serve(config: DaemonConfig, options: DaemonOptions, stop: threading.Event) -> None:
    """Open the zenoh session and run the daemon until ``stop`` is set; always cleans up."""
    from robot_daemon.recording import daemon_hook  # MCAP recording, live Foxglove view

    z = config.zenoh
    security, insecure = link_security(config)  # fails fast: keys, endpoints (issue 15)
    daemon = Daemon(config, options)
    notifier = SystemdNotifier()
    tls = None
    if security is not None:  # the live Foxglove view may then serve wss:// off the machine
        tls = (security.identity.cert.read_bytes(), security.identity.key.read_bytes())
    recorder = daemon_hook.build_daemon_recorder(config, options, daemon.now, tls)
    try:
        if z.mode == "client" and not _wait_for_router(z.connect, stop):
            return
        with open_session(
            list(z.listen),
            list(z.connect),
            z.mode,
            z.lease_ms,
            security=security,
            insecure=insecure,
        ) as session:
            link = daemon_hook.make_link(session, daemon, recorder)
            try:
                daemon.run(link, stop, notifier)
            finally:
                link.close()
                notifier.close()
    finally:
        if recorder is not None:
            recorder.close()  # finish the file even if the session never opened
    logger.info("daemon stopped")
