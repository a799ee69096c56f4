"""Kidnap scenario (issue 16): the robot is carried away, and must notice and find itself.

During a tour with people on the simulated world (the runner's default world), the simulated
robot is teleported ``KIDNAPS`` times, alternately while standing (its route cancelled and the
robot stopped: it stands at a tour stop) and while driving, between any two places at least
``MIN_KIDNAP_M`` apart: topological nodes when the map has a topological graph, random free
poses otherwise (Willow Garage). Odometry does not see a teleport.

A robot kidnapped standing at a tour stop gets its next leg from the station, as the shipped
station gives it: ``TOUR_DWELL_S`` after the robot came to rest the visitor asks for the next
place (a `GoTo` of the graph's node, a `GoToPose` without a graph) through the system's real
`Supervisor`. If the robot reports a pose then, the supervisor plans the route from it; if it
lost the pose it had (lost, searching, turning), the supervisor sends the goal alone
(`Supervisor.update`, issue 16): the robot serves a command, may turn to look around
(`look_around`) while it searches and plans from the pose it finds. After the kidnap is
settled the task is cancelled and the scenario's own wander goes on. ``idle_after_kidnap``
(``--idle-after-kidnap``) leaves the robot idle instead (nobody asks for the next leg): an idle
robot never turns by itself (no motion nobody commanded), so it searches standing still and
turns only for the operator's "Relocalise". Driving kidnaps are the same in both.
For each kidnap the figures are taken from the simulator's ground truth (metrics only;
nothing of it reaches the robot):

* ``detected``: the robot's localisation state left ``ok`` within ``WINDOW_S`` (lost or
  searching); ``detect_s``: from the teleport to that moment;
* ``relocalised``: it was ``ok`` again within ``WINDOW_S`` with its estimate within
  ``CORRECT_M`` of the truth, without a person; ``relocalise_s``: from the teleport;
* ``relocalised_within_5s`` / ``_10s``: of those, how many within 5 s / 10 s of the teleport;
* ``wrong_relocalisations``: it reported ``ok`` after the kidnap with the estimate more than
  ``WRONG_M`` from the truth (the failure that must never happen);
* ``help_requests``: the robot asked for a person ("Help me!").

A kidnap not resolved within ``WINDOW_S`` is resolved by the operator (the true pose is set) so
the run goes on. ``--cold-start`` instead starts the robot ``COLD_STARTS`` times with its pose
unset at random free poses and reports the same figures (``detected`` is then every trial);
every time is from power-on (simulated time 0, pose unset). At power-on the operator presses
the station's "Relocalise" (`SimulatedSystem.relocalise`: the station's button sends the link's
``Relocalise``, the daemon calls `RobotStack.relocalise`), which is what the shipped system
offers a robot that never had a pose: the station's supervisor sends no route to it (thesis
§5.2.2.1: the initial pose is set, or found, first). That is a command, so the robot may turn to
look around (`look_around`, reason "request"). ``idle_at_power_on`` (``--idle-at-power-on``):
nobody presses anything; the robot searches standing still (no motion nobody commanded) and
asks for help where one standing scan fits several places.

``relocalise_s_list`` / ``detect_s_list`` are the times of every relocalised / detected trial,
so runs can be pooled (the targets are over all kidnaps, not per seed).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.supervisor import GoTo, GoToPose
from interbot_core.topics import RouteMsg
from robot_daemon.config import DEFAULT_MAP, DEFAULT_TOPO
from robot_daemon.localisation.localiser import LocaliserState
from robot_daemon.scenarios.runner import ScenarioOptions, ScenarioResult, SimulatedSystem

logger = logging.getLogger(__name__)

KIDNAPS = 8
COLD_STARTS = 10
MIN_KIDNAP_M = 3.0  # [m] closer kidnaps may stay in the tracker's basin
WINDOW_S = 30.0  # [s] to detect and relocalise before the operator steps in
CORRECT_M = 0.3  # [m] a relocalisation this close to the truth is right
WRONG_M = 0.5  # [m] ... this far is wrong
MIN_CLEARANCE_M = 0.45  # [m] targets this far from walls (the footprint fits)
DRIVE_S = (8.0, 25.0)  # [s] driving between kidnaps (uniform)
TOUR_DWELL_S = 5.0  # [s] at a tour stop until the visitor taps Resume (the tour scenario's)
WANDER_ROUTE_IDS = 10_000  # the scenario's own routes: ids apart from the station's (1, 2, ...)


@dataclass
class KidnapRecord:
    standing: bool
    detect_s: float | None = None
    relocalise_s: float | None = None
    wrong: bool = False
    help: int = 0


@dataclass
class _Tally:
    records: list[KidnapRecord] = field(default_factory=list)

    def figures(self) -> dict[str, Any]:
        recs = self.records
        det = [r.detect_s for r in recs if r.detect_s is not None]
        rel = [r.relocalise_s for r in recs if r.relocalise_s is not None]

        def stat(values: list[float], fn: Callable[[Any], Any]) -> float | None:
            return round(float(fn(np.asarray(values))), 2) if values else None

        return {
            "kidnaps": len(recs),
            "standing": sum(r.standing for r in recs),
            "detected": len(det),
            "relocalised": len(rel),
            "wrong_relocalisations": sum(r.wrong for r in recs),
            "detect_s_median": stat(det, np.median),
            "detect_s_max": stat(det, np.max),
            "relocalise_s_median": stat(rel, np.median),
            "relocalise_s_max": stat(rel, np.max),
            # every trial's time, to pool runs (the median over all kidnaps of all seeds)
            "detect_s_list": det,
            "relocalise_s_list": rel,
            # The targets: kidnaps relocalised within 10 s, cold starts within 5 s.
            "relocalised_within_5s": sum(t <= 5.0 for t in rel),
            "relocalised_within_10s": sum(t <= 10.0 for t in rel),
            "help_requests": sum(r.help for r in recs),
        }


def topo_for(map_yaml: Path, topo_yaml: Path) -> Path | None:
    """The topological map to use: the one given, ``<map>_topo.yaml`` beside the map, the
    default one for the default map, else None (random free poses). The default graph given
    with another map is taken as "not given" (ISR's nodes do not fit another building)."""
    if topo_yaml.resolve() != DEFAULT_TOPO.resolve():
        return topo_yaml
    beside = map_yaml.with_name(map_yaml.stem + "_topo.yaml")
    if beside.is_file():
        return beside
    if map_yaml.resolve() == DEFAULT_MAP.resolve():
        return DEFAULT_TOPO
    return None


def free_poses(grid: OccupancyGrid, clearance_m: float) -> np.ndarray:
    """(N, 2) centres of known-free cells at least ``clearance_m`` from any blocked cell."""
    from robot_daemon.scenarios.runner import free_space_distance

    rows, cols = np.nonzero(free_space_distance(grid) >= clearance_m)
    xs, ys = grid.cell_to_world(rows, cols)
    return np.column_stack((xs, ys))


class KidnapRun:
    """One system, its places and the bookkeeping shared by both variants."""

    def __init__(self, options: ScenarioOptions, topo: Path | None, rng: np.random.Generator):
        self.options = options
        self.topo_given = topo is not None
        # Without a graph of its own the system still needs one for the station's supervisor,
        # which this scenario does not use: the default graph stands in, unused.
        self.sys_options = replace(options, topo_yaml=topo or DEFAULT_TOPO)
        self.rng = rng
        self.system: SimulatedSystem | None = None
        self._free: np.ndarray | None = None

    def places(self, system: SimulatedSystem) -> list[Pose2D]:
        if self.topo_given:
            nodes = [n.pose for n in system.topo.nodes]
            return [p for p in nodes if system.sim.world.clearance_at(p.x, p.y) >= 0.35]
        if self._free is None:
            self._free = free_poses(system.grid, MIN_CLEARANCE_M)
        picks = self.rng.choice(self._free.shape[0], size=min(200, self._free.shape[0]))
        return [Pose2D(float(x), float(y), 0.0) for x, y in self._free[picks]]

    def target(self, system: SimulatedSystem, away_from: Pose2D) -> Pose2D:
        """A place at least MIN_KIDNAP_M away, facing a random direction."""
        options = [p for p in self.places(system) if p.distance_to(away_from) >= MIN_KIDNAP_M]
        place = options[int(self.rng.integers(len(options)))]
        return Pose2D(place.x, place.y, float(self.rng.uniform(-math.pi, math.pi)))

    def next_task(self, system: SimulatedSystem, away_from: Pose2D) -> GoTo | GoToPose:
        """The visitor's next place as a station task: a node of the graph at least
        MIN_KIDNAP_M away, or without a graph a free pose (`target`)."""
        if not self.topo_given:
            return GoToPose(self.target(system, away_from))
        ids = [
            n.id
            for n in system.topo.nodes
            if system.sim.world.clearance_at(n.pose.x, n.pose.y) >= 0.35
            and n.pose.distance_to(away_from) >= MIN_KIDNAP_M
        ]
        return GoTo(ids[int(self.rng.integers(len(ids)))])


def _watch(
    system: SimulatedSystem,
    record: KidnapRecord,
    start: float,
    then: tuple[float, Callable[[], None]] | None = None,
) -> None:
    """Step until relocalised (right or wrong) or WINDOW_S passes; fill ``record``.
    ``then``: (time, action) done once on the way (the tour's next leg)."""
    stack, sim = system.stack, system.sim
    help_before = stack.relocalisation.help_requests
    left_ok = False
    while system.now - start < WINDOW_S:
        if then is not None and system.now >= then[0] - 1e-9:
            then[1]()
            then = None
        system.step()
        state = stack.localisation_state
        if state is not LocaliserState.OK:
            if record.detect_s is None:
                record.detect_s = round(system.now - start, 2)
            left_ok = True
        elif left_ok:
            estimate = stack.pose
            error = math.inf if estimate is None else estimate.distance_to(sim.true_pose())
            if error > WRONG_M:
                record.wrong = True
                logger.error("WRONG relocalisation: %.2f m from the truth", error)
            elif error <= CORRECT_M:
                record.relocalise_s = round(system.now - start, 2)
            break
    record.help = stack.relocalisation.help_requests - help_before


def _operator_fixes(system: SimulatedSystem) -> None:
    """The operator sets the true pose so the run can go on (counted as not relocalised)."""
    stack = system.stack
    stack.set_initial_pose(system.sim.true_pose(), system.now)
    system.run_until(lambda: stack.localisation_state is LocaliserState.OK, 2.0)


def _drive_somewhere(run: KidnapRun, system: SimulatedSystem, route_id: int) -> None:
    """Send the robot to a place (a tour-like wander between places) at least MIN_KIDNAP_M
    from where it believes it is."""
    pose = system.stack.pose or system.sim.true_pose()
    goal = run.target(system, pose)
    msg = RouteMsg(route_id, ((goal.x, goal.y, goal.yaw),))
    try:
        system.stack.set_route(msg, system.now)
    except ValueError as exc:  # StackError: goal not free (cannot happen for free places)
        logger.warning("route refused: %s", exc)


def _station_next_leg(run: KidnapRun, system: SimulatedSystem) -> None:
    """The visitor asks for the next place (away from where the robot truly is): a task for
    the station's supervisor, which sends the robot its leg (module docstring)."""
    system.apply(system.supervisor.submit(run.next_task(system, system.sim.true_pose())))


def run_kidnaps(options: ScenarioOptions, topo: Path | None, count: int = KIDNAPS) -> _Tally:
    rng = np.random.default_rng(options.seed)
    run = KidnapRun(options, topo, rng)
    tally = _Tally()
    probe = SimulatedSystem(run.sys_options, start_pose=_start_pose(run, options))
    system = probe
    stack, sim = system.stack, system.sim
    system.localise()
    route_id = WANDER_ROUTE_IDS
    for k in range(count):
        standing = k % 2 == 0
        route_id += 1
        _drive_somewhere(run, system, route_id)
        drive_s = float(rng.uniform(*DRIVE_S))
        system.run_until(lambda: False, drive_s)
        at_stop = system.now
        if standing:
            stack.cancel_route(system.now, "kidnap scenario: stand still")
            system.run_until(lambda: sim.true_velocity() == (0.0, 0.0), 5.0)
            at_stop = system.now  # at a tour stop from here
            system.run_until(lambda: False, 1.0)
        else:
            if stack.route is None or stack.route.finished:
                route_id += 1
                _drive_somewhere(run, system, route_id)
            system.run_until(lambda: abs(sim.true_velocity()[0]) > 0.1, 20.0)
        if stack.localisation_state is not LocaliserState.OK:
            _operator_fixes(system)  # a loss before the kidnap is not this scenario's figure
        target = run.target(system, sim.true_pose())
        record = KidnapRecord(standing=standing)
        sim.teleport(target)
        next_leg = None
        if standing and not options.idle_after_kidnap:
            # The visitor asks for the next stop, from a stream of its own (the kidnaps are
            # those of an idle run), away from where the robot now truly stands.
            leg_run = KidnapRun(options, topo, np.random.default_rng([options.seed, k, 17]))
            next_leg = (at_stop + TOUR_DWELL_S, partial(_station_next_leg, leg_run, system))
        _watch(system, record, system.now, next_leg)
        # The kidnap is settled: the station's task (if any) is cancelled, so the scenario's
        # own wander goes on.
        system.apply(system.supervisor.cancel())
        system.apply(system.supervisor.clear_queue())
        tally.records.append(record)
        logger.info("kidnap %d (%s): %s", k, "standing" if standing else "moving", record)
        if record.relocalise_s is None:
            _operator_fixes(system)
    return tally


def _start_pose(run: KidnapRun, options: ScenarioOptions) -> Pose2D | None:
    if run.topo_given:
        return None  # the graph's home
    from interbot_core.occupancy_grid import load_map

    grid = load_map(options.map_yaml)
    free = free_poses(grid, 1.0)
    x, y = free[int(run.rng.integers(free.shape[0]))]
    return Pose2D(float(x), float(y), 0.0)


def cold_start_poses(options: ScenarioOptions, count: int = COLD_STARTS) -> list[Pose2D]:
    """Where the robot is switched on: ``count`` random free poses facing random directions."""
    rng = np.random.default_rng(options.seed)
    from interbot_core.occupancy_grid import load_map

    free = free_poses(load_map(options.map_yaml), MIN_CLEARANCE_M)
    poses = []
    for _ in range(count):
        x, y = free[int(rng.integers(free.shape[0]))]
        poses.append(Pose2D(float(x), float(y), float(rng.uniform(-math.pi, math.pi))))
    return poses


def power_on(options: ScenarioOptions, topo: Path | None, k: int, start: Pose2D) -> SimulatedSystem:
    """Cold start ``k``: a system switched on at ``start`` with its pose unset; the operator
    presses "Relocalise" at once unless ``options.idle_at_power_on``."""
    run = KidnapRun(options, topo, np.random.default_rng(options.seed))
    system = SimulatedSystem(replace(run.sys_options, seed=options.seed + k), start_pose=start)
    if not options.idle_at_power_on:
        system.relocalise()  # the station's "Relocalise", pressed at power-on
    return system


def run_cold_starts(
    options: ScenarioOptions, topo: Path | None, count: int = COLD_STARTS
) -> _Tally:
    """``count`` power-ons at random free poses (`cold_start_poses`, `power_on`)."""
    tally = _Tally()
    for k, start in enumerate(cold_start_poses(options, count)):
        system = power_on(options, topo, k, start)
        record = KidnapRecord(standing=True)
        _watch(system, record, system.now)
        tally.records.append(record)
        logger.info("cold start %d at %s: %s", k, start, record)
    return tally


def run(options: ScenarioOptions, count: int | None = None) -> ScenarioResult:
    """The scenario; ``count`` kidnaps (or cold starts) instead of the default number."""
    topo = topo_for(options.map_yaml, options.topo_yaml)
    cold = options.cold_start
    if cold:
        tally = run_cold_starts(options, topo, count or COLD_STARTS)
    else:
        tally = run_kidnaps(options, topo, count or KIDNAPS)
    figures = tally.figures()
    figures.update(
        {
            "map": str(options.map_yaml),
            "targets": "topological nodes" if topo is not None else "random free poses",
            "cold_start": cold,
            # cold starts: the operator presses "Relocalise" at power-on (not with
            # --idle-at-power-on); kidnaps: a robot kidnapped standing gets its next leg from
            # the station's supervisor after the dwell (not with --idle-after-kidnap)
            "commanded": not options.idle_at_power_on if cold else not options.idle_after_kidnap,
            "people": options.people,
            "seed": options.seed,
        }
    )
    f = figures
    if cold:
        pressed = "idle at power-on" if options.idle_at_power_on else '"Relocalise" at power-on'
        title = f"cold start anywhere, {pressed}"
    else:
        title = "kidnapped robot (standing and moving)"
    table = "\n".join(
        [
            f"Kidnap scenario (issue 16): {title} on {options.map_yaml.name}",
            "Kidnaps  Detected  Relocalised  Wrong  Help  detect s (med/max)  relocalise s (med/max)",
            f"{f['kidnaps']:>7}  {f['detected']:>8}  {f['relocalised']:>11}"
            f"  {f['wrong_relocalisations']:>5}  {f['help_requests']:>4}"
            f"  {_pair(f['detect_s_median'], f['detect_s_max']):>18}"
            f"  {_pair(f['relocalise_s_median'], f['relocalise_s_max']):>22}",
        ]
    )
    return ScenarioResult("kidnap", table, figures)


def _pair(a: float | None, b: float | None) -> str:
    if a is None or b is None:
        return "-"
    return f"{a:.2f}/{b:.2f}"
