"""Reckless drivers (issue 17): anyone may drive, nobody gets hit.

Scripted drivers push the joystick at walls, through narrow doors, around corridor corners and at
people walking toward the robot, from many starts on the simulated ISR floor, in three set-ups:

* ``assisted``: assisted teleoperation on (the tablet's default), collision monitor on;
* ``unassisted``: the Base Station with assistance off (its default): the monitor alone;
* ``unprotected``: both off (the robot before issue 17), for reference.

The drivers are reckless on purpose: they push at full joystick (0.6 m/s, 0.8 rad/s, the
station's teleoperation limits of the mission scenario) and never slow down for an obstacle.

* ``wall``: a constant push straight ahead from a free pose facing a wall 1-3 m away (random
  headings: head-on and glancing). Progress: distance made along the pushed direction.
* ``door``: from the corridor beside a room's door (0.35 m off its axis, either side), the
  driver steers at a point 2.3 m through the door from the door's topological node; bearing
  control on the pose the station shows (the robot's estimate). Progress: how much nearer the
  target the robot got. ``time_to_doorway_s``: until the robot's centre is 1.4 m past the node
  (the whole footprint through the frame of the narrowest door).
* ``corner``: from 4 m before a corridor corner the driver steers straight at a point 3 m past
  it, cutting the corner.
* ``person``: along a long straight corridor segment while a person walks toward the robot.

Figures (ground truth, metrics only): ``runs``, ``collisions`` (assisted),
``collisions_unassisted``, ``collisions_unprotected``, ``min_clearance_m`` (assisted, and per
set-up), ``progress_m`` (assisted total) and ``progress_ratio`` (assisted / unassisted and
assisted / unprotected), ``time_to_doorway_s`` through the narrowest door (assisted and
unassisted; None if it never got through).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np

from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.topological_map import TopologicalMap
from robot_daemon.scenarios.runner import (
    ScenarioOptions,
    ScenarioResult,
    SimulatedSystem,
    clearance_along,
    daemon_localiser_config,
    free_space_distance,
    straight_segments,
)
from robot_daemon.stack import StackConfig

SETUPS = ("assisted", "unassisted", "unprotected")
V_MAX = 0.6  # [m/s] the station's teleoperation limit (mission scenario's operator)
W_MAX = 0.8  # [rad/s]
DOOR_OFFSET = 0.35  # [m] start off the door's axis
DOOR_TARGET = 2.3  # [m] from the door node through the door
DOOR_THROUGH = 1.4  # [m] past the node: the footprint has cleared the frame
CORNER_BEFORE = 4.0  # [m]
CORNER_AFTER = 3.0  # [m]
WALLS = 8
PEOPLE = 3


@dataclass(frozen=True)
class Run:
    kind: str  # wall | door | corner | person
    start: Pose2D
    target: tuple[float, float]  # [m] map frame (wall: a point far along the push)
    time_limit: float  # [s]
    label: str
    door_width: float = math.nan  # [m] door runs: the narrowest free width on the door's axis
    person: tuple[tuple[float, float], tuple[float, float]] | None = None


@dataclass
class Outcome:
    run: Run
    collisions: int
    min_clearance: float
    progress: float
    through_s: float | None


def _free(system: SimulatedSystem, pose: Pose2D) -> bool:
    sim = system.sim
    return not sim.world.footprint_hits_wall(sim.config.footprint, pose)


def plan_runs(system: SimulatedSystem, seed: int) -> list[Run]:
    """The runs on this map: doors, corners, walls, people (deterministic for a seed)."""
    grid, topo = system.grid, system.topo
    distance = free_space_distance(grid)
    runs: list[Run] = []
    runs += _door_runs(system, topo, distance)
    runs += _corner_runs(system, topo)
    runs += _wall_runs(system, distance, np.random.default_rng(seed))
    runs += _person_runs(system, topo)
    return runs


def _door_runs(system: SimulatedSystem, topo: TopologicalMap, distance: np.ndarray) -> list[Run]:
    out: list[Run] = []
    for node in topo.nodes:
        p = node.pose
        c, s = math.cos(p.yaw), math.sin(p.yaw)
        target = (p.x + DOOR_TARGET * c, p.y + DOOR_TARGET * s)
        narrow = clearance_along(distance, system.grid, (p.x, p.y), target)
        if not 0.35 <= narrow <= 0.7:  # 0.7-1.4 m wide: a door on the way, not a corridor
            continue
        rows, cols = system.grid.world_to_cell(np.array([target[0]]), np.array([target[1]]))
        if float(distance[rows[0], cols[0]]) < 0.45:
            continue
        side = 1.0 if len(out) % 2 else -1.0  # alternate sides from door to door
        start = Pose2D(
            p.x - 0.5 * c - side * DOOR_OFFSET * s,
            p.y - 0.5 * s + side * DOOR_OFFSET * c,
            p.yaw,
        )
        if _free(system, start):
            out.append(
                Run("door", start, target, 25.0, f"door {node.name} ({side:+.0f})", 2 * narrow)
            )
    return out


def _corner_runs(system: SimulatedSystem, topo: TopologicalMap) -> list[Run]:
    out = []
    for node in topo.nodes:
        nbrs = topo.neighbours(node.id)
        if len(nbrs) != 2:
            continue
        p = node.pose
        dirs = [math.atan2(q.y - p.y, q.x - p.x) for q in (topo.node(n).pose for n in nbrs)]
        turn = abs(angle_diff(dirs[0], dirs[1]))
        if not math.radians(60) <= turn <= math.radians(120):
            continue
        for a, b in ((0, 1), (1, 0)):
            start_xy = (
                p.x + CORNER_BEFORE * math.cos(dirs[a]),
                p.y + CORNER_BEFORE * math.sin(dirs[a]),
            )
            target = (
                p.x + CORNER_AFTER * math.cos(dirs[b]),
                p.y + CORNER_AFTER * math.sin(dirs[b]),
            )
            start = Pose2D(*start_xy, dirs[a] + math.pi)
            if _free(system, start):
                out.append(Run("corner", start, target, 25.0, f"corner {node.name} ({a}->{b})"))
    return out


def _wall_runs(
    system: SimulatedSystem, distance: np.ndarray, rng: np.random.Generator
) -> list[Run]:
    grid = system.grid
    free = np.argwhere(distance >= 0.7)
    out: list[Run] = []
    for _ in range(5000):
        if len(out) >= WALLS:
            break
        row, col = free[rng.integers(len(free))]
        x, y = grid.cell_to_world(int(row), int(col))
        yaw = float(rng.uniform(-math.pi, math.pi))
        start = Pose2D(float(x), float(y), yaw)
        # March along the heading to the wall.
        steps = np.arange(0.05, 3.5, 0.05)
        xs, ys = x + steps * math.cos(yaw), y + steps * math.sin(yaw)
        rows, cols = grid.world_to_cell(xs, ys)
        inside = grid.in_bounds(rows, cols)
        if not bool(np.all(inside)):
            continue
        hit = np.nonzero(distance[rows, cols] < 0.05)[0]
        if hit.size == 0 or not 1.0 <= steps[hit[0]] <= 3.0 or not _free(system, start):
            continue
        far = (float(x) + 10 * math.cos(yaw), float(y) + 10 * math.sin(yaw))
        out.append(Run("wall", start, far, 10.0, f"wall at {steps[hit[0]]:.1f} m"))
    return out


def _person_runs(system: SimulatedSystem, topo: TopologicalMap) -> list[Run]:
    out = []
    for seg in straight_segments(system.grid, topo, 0.9)[: PEOPLE * 2 : 2]:
        h = seg.heading
        c, s = math.cos(h), math.sin(h)
        length = min(seg.length, 10.0)
        start = Pose2D(seg.start[0] + 0.5 * c, seg.start[1] + 0.5 * s, h)
        end = (seg.start[0] + (length - 0.5) * c, seg.start[1] + (length - 0.5) * s)
        if _free(system, start):
            walk = ((end[0], end[1]), (start.x + c, start.y + s))
            out.append(
                Run("person", start, end, length / V_MAX + 15.0, f"person {seg.nodes}", person=walk)
            )
    return out


# -- driving --------------------------------------------------------------------------------


def _command(run: Run, pose: Pose2D | None) -> tuple[float, float]:
    """The reckless driver's joystick: full push, steering by bearing (no obstacle awareness)."""
    if pose is None:
        return 0.0, 0.0
    if run.kind == "wall":
        return V_MAX, 0.0
    bearing = angle_diff(math.atan2(run.target[1] - pose.y, run.target[0] - pose.x), pose.yaw)
    w = max(-W_MAX, min(W_MAX, 1.5 * bearing))
    v = V_MAX if abs(bearing) < 0.8 else 0.0
    return v, w


def _progress(run: Run, start: Pose2D, end: Pose2D) -> float:
    if run.kind == "wall":
        return (end.x - start.x) * math.cos(start.yaw) + (end.y - start.y) * math.sin(start.yaw)
    d0 = math.hypot(run.target[0] - start.x, run.target[1] - start.y)
    d1 = math.hypot(run.target[0] - end.x, run.target[1] - end.y)
    return d0 - d1


def _door_axis(run: Run) -> tuple[float, float, float]:
    """(node x, node y, yaw) of a door run: the node is DOOR_TARGET before the target."""
    yaw = run.start.yaw
    return (
        run.target[0] - DOOR_TARGET * math.cos(yaw),
        run.target[1] - DOOR_TARGET * math.sin(yaw),
        yaw,
    )


def _wait_for_people_to_clear(
    system: SimulatedSystem, start: Pose2D, max_wait: float = 30.0
) -> None:
    """Do not put the robot down on (or right next to) a person walking past the start."""
    sim = system.sim
    t0 = system.now
    while system.now - t0 < max_wait:
        circles = sim.crowd.circles()
        if circles.size == 0:
            return
        gaps = sim.config.footprint.distance_to_points(start, circles[:, :2]) - circles[:, 2]
        if float(gaps.min()) > 1.0:
            return
        system.step()


def drive(system: SimulatedSystem, run: Run) -> Outcome:
    """One run on ``system`` (reused between runs: teleported and re-localised)."""
    sim, stack = system.sim, system.stack
    stack.on_twist("station_vel", 0.0, 0.0, system.now)
    for _ in range(10):
        system.step()
    _wait_for_people_to_clear(system, run.start)
    sim.teleport(run.start)
    system.start_pose = run.start
    system.localise()
    if run.person is not None:
        sim.add_person([run.person[0], run.person[1]])
    for _ in range(4):  # a scan or two of the new place before the push
        system.step()
    collisions0 = sim.collisions
    t0 = system.now
    clearance = math.inf
    through: float | None = None
    next_cmd = system.now
    while system.now - t0 < run.time_limit:
        if system.now + 1e-9 >= next_cmd:
            next_cmd += 0.1
            stack.on_twist("station_vel", *_command(run, stack.pose), system.now)
        system.step()
        truth = sim.true_pose()
        clearance = min(clearance, sim.min_clearance())
        if run.kind == "door" and through is None:
            nx, ny, yaw = _door_axis(run)
            if (truth.x - nx) * math.cos(yaw) + (truth.y - ny) * math.sin(yaw) >= DOOR_THROUGH:
                through = system.now - t0
        if (
            run.kind != "wall"
            and math.hypot(truth.x - run.target[0], truth.y - run.target[1]) < 0.3
        ):
            break
    stack.on_twist("station_vel", 0.0, 0.0, system.now)
    progress = _progress(run, run.start, sim.true_pose())
    return Outcome(run, sim.collisions - collisions0, clearance, progress, through)


def make_system(options: ScenarioOptions, setup: str) -> SimulatedSystem:
    if setup not in SETUPS:
        raise ValueError(f"setup must be one of {SETUPS}, got {setup!r}")
    config = StackConfig(localiser=daemon_localiser_config())
    if setup == "unprotected":
        safety = config.motion_guard
        config = dataclasses.replace(
            config,
            motion_guard=safety.replace(
                monitor=msgspec.structs.replace(safety.monitor, enabled=False)
            ),
        )
    system = SimulatedSystem(options, stack_config=config, autonomy=False)
    system.stack.set_teleop_assist("station_vel", setup == "assisted", system.now)
    return system


def run_setup(
    options: ScenarioOptions, setup: str, limit: int | None = None, max_run_s: float | None = None
) -> list[Outcome]:
    """Every planned run (the first ``limit``; each cut at ``max_run_s`` [s]) in one set-up."""
    system = make_system(options, setup)
    runs = plan_runs(system, options.seed)
    if limit is not None:
        runs = runs[:limit]
    if max_run_s is not None:
        runs = [dataclasses.replace(r, time_limit=min(r.time_limit, max_run_s)) for r in runs]
    return [drive(system, run) for run in runs]


def _summary(outcomes: list[Outcome]) -> dict[str, Any]:
    doors = [o for o in outcomes if o.run.kind == "door"]
    narrow = min((o.run.door_width for o in doors), default=math.nan)
    through = [o.through_s for o in doors if o.run.door_width == narrow]
    times = [t for t in through if t is not None]
    return {
        "runs": len(outcomes),
        "collisions": sum(o.collisions for o in outcomes),
        "runs_with_collision": sum(1 for o in outcomes if o.collisions),
        "min_clearance_m": round(min((o.min_clearance for o in outcomes), default=math.nan), 3),
        "progress_m": round(sum(o.progress for o in outcomes), 2),
        "time_to_doorway_s": round(float(np.mean(times)), 2)
        if len(times) == len(through) and times
        else None,
        "doorway_passes": f"{len(times)}/{len(through)}",
        "narrowest_door_m": round(narrow, 2) if math.isfinite(narrow) else None,
        "by_kind": {
            kind: {
                "runs": len(sel),
                "collisions": sum(o.collisions for o in sel),
                "progress_m": round(sum(o.progress for o in sel), 2),
            }
            for kind in ("wall", "door", "corner", "person")
            if (sel := [o for o in outcomes if o.run.kind == kind])
        },
    }


def run(
    options: ScenarioOptions,
    setups: tuple[str, ...] = SETUPS,
    limit: int | None = None,
    max_run_s: float | None = None,
) -> ScenarioResult:
    results = {setup: _summary(run_setup(options, setup, limit, max_run_s)) for setup in setups}
    a = results.get("assisted", {})
    figures: dict[str, Any] = {
        "runs": a.get("runs"),
        "collisions": a.get("collisions"),
        "collisions_unassisted": results.get("unassisted", {}).get("collisions"),
        "collisions_unprotected": results.get("unprotected", {}).get("collisions"),
        "min_clearance_m": a.get("min_clearance_m"),
        "progress_m": a.get("progress_m"),
        "time_to_doorway_s": a.get("time_to_doorway_s"),
        "time_to_doorway_unassisted_s": results.get("unassisted", {}).get("time_to_doorway_s"),
        "setups": results,
        "seed": options.seed,
        "people": options.people,
    }
    for other in ("unassisted", "unprotected"):
        if other in results and "assisted" in results:
            theirs = results[other]["progress_m"]
            figures[f"progress_ratio_vs_{other}"] = (
                round(a["progress_m"] / theirs, 3) if theirs > 0 else None
            )
    return ScenarioResult("teleop", format_table(results), figures)


def format_table(results: dict[str, dict[str, Any]]) -> str:
    lines = [
        "Reckless drivers (issue 17): collisions, clearance and progress per set-up",
        "set-up       runs  collisions  runs hit  min clear (cm)  progress (m)  door (s)  door passes",
    ]
    for setup, f in results.items():
        door = "-" if f["time_to_doorway_s"] is None else f"{f['time_to_doorway_s']:.1f}"
        lines.append(
            f"{setup:<12} {f['runs']:<5} {f['collisions']:<11} {f['runs_with_collision']:<9} "
            f"{f['min_clearance_m'] * 100:<15.1f} {f['progress_m']:<13.1f} {door:<9} {f['doorway_passes']}"
        )
    lines.append("")
    lines.append("per kind (runs / collisions / progress m): " + "; ".join(
        f"{setup}: " + ", ".join(f"{k} {v['runs']}/{v['collisions']}/{v['progress_m']:.1f}" for k, v in f["by_kind"].items())
        for setup, f in results.items()
    ))  # fmt: skip
    return "\n".join(lines)
