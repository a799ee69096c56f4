"""Test Scenario 3 (thesis §6.3, Tables 6.5-6.7, Figs. 6.4/6.5): one mission, three ways to drive.

The mission: from the start (node 0, localised) into the request room (the Mecatronics Lab: the
``requests: true`` node whose name contains "Mecatronics", else the first request node), where a
Delivery request is shown on the tablet and accepted by the person in the room
``ACCEPT_AFTER_S`` later, then on to the Bar (the node named "Bar", else the last tour node that
is neither the start nor the room), the end of the mission. Modes:

* ``autonomous``: the supervisor sends the routes and the robot's planner drives (thesis §6.3.1).
* ``teleoperation``: the robot gets the routes but its navigation stays paused (it only judges
  progress, as it does whoever drives); a scripted operator (`HumanDriver`) drives on ``station_vel`` every 100 ms. It sees what the station shows (the
  robot's published pose and scan, the map, the supervisor's route) and never the truth, and
  sees it late: ``PERCEPTION_DELAY`` after the robot published it (video, pose and scan on the
  station's screen), and its joystick moves ``REACTION_TIME`` after it decides. It plans a path to
  the route's current node with the robot's global planner on the static map, follows it by pure
  pursuit (lookahead 0.8 m) at no more than autonomy's speed limits (the stack's
  ``max_linear_speed`` and ``max_angular_speed``: a fair comparison, issue 17), slows with the
  free range ahead in the scan and with path curvature, turns in place when the path points
  away, and at the goal turns to the goal's heading.
* ``shared`` (thesis §6.3.2): routes are sent and the same operator drives only on long straight
  stretches (the path ahead straight within 20 deg for >= 4 m, robot aligned, no narrow passage
  beside it in the scan, >= 3 m from the leg's goal); at corners, doorways, inside rooms and near
  the goal it releases the joystick (one zero command, then silence) and autonomy takes over once
  ``station_vel`` times out; the stack replans from where the robot is.
* ``teleoperation_assisted`` and ``shared_assisted``: the same with the station's assisted
  teleoperation switched on (``teleop_assist``); the collision monitor is on in every mode. The
  figures ``assistance`` compare each pair (duration, collisions, clearance, speed).

Checkpoints (Table 6.6): Start -> P1 -> Task -> P2 -> P3 -> End, with Task = the request shown
in the room and End = the delivery finished. P1 is the intermediate topological node of the first
leg nearest half its length; P2 and P3 the intermediate nodes of the second leg nearest 1/3 and 2/3
of it; when the second leg has too few intermediate nodes (on ISR floor 0 it is Mecatronics Lab
-> its door -> Bar), the missing checkpoint is the point at that fraction of the leg's polyline.
A checkpoint is passed at the TRUE robot's closest approach (metrics only) within its leg, P3
after P2. Clearance, speed and localisation figures are the shared `Metrics` (ground truth).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.laser_scan import LaserScan
from interbot_core.supervisor import (
    Delivery,
    RequestShown,
    SupervisorState,
    TaskFinished,
)
from interbot_core.topological_map import TopologicalMap
from robot_daemon.planning.config import PlannerConfig
from robot_daemon.planning.costmap import Costmap
from robot_daemon.planning.global_planner import GlobalPlanner, PlanningError
from robot_daemon.scenarios.runner import (
    ScenarioOptions,
    ScenarioResult,
    SimulatedSystem,
    auto_answer_requests,
    run_ticks,
)

logger = logging.getLogger(__name__)

MODES = ("autonomous", "teleoperation", "shared", "teleoperation_assisted", "shared_assisted")
ACCEPT_AFTER_S = 3.0  # [s] the person in the room reads the request, then accepts
PERCEPTION_DELAY = 0.3  # [s] robot state -> the operator's eyes (link, video, screen refresh)
REACTION_TIME = 0.25  # [s] the operator's decision -> the joystick moves
WAIT_BEFORE_EVADING = 3.0  # [s] standing behind something before steering around it
EVADE_S = 1.5  # [s]
LOOKAHEAD = 0.8  # [m] pure pursuit
STRAIGHT_ENTER = 4.0  # [m] shared control: straight path ahead to take the joystick
STRAIGHT_STAY = 1.5  # [m] ... and to keep it
GOAL_HANDOVER = 3.0  # [m] shared control: autonomy does the last metres of each leg


class MissionScenarioError(RuntimeError):
    """The topological map lacks what the mission needs; the message names it."""


@dataclass(frozen=True)
class Checkpoint:
    name: str
    x: float
    y: float
    node: int | None  # None: a point on the leg, not a node

    def label(self, topo: TopologicalMap) -> str:
        if self.node is None:
            return f"{self.name} ({self.x:.1f}, {self.y:.1f})"
        return f"{self.name} node {self.node} ({topo.node(self.node).name})"


def mission_nodes(topo: TopologicalMap) -> tuple[int, int]:
    """(request room, delivery target) by name, with generic fallbacks."""
    rooms = topo.request_nodes()
    if not rooms:
        raise MissionScenarioError(f"no node of {topo.source} takes requests ('requests: true')")
    room = next((n for n in rooms if "mecatronic" in n.name.lower()), rooms[0]).id
    bar = next((n.id for n in topo.nodes if n.name.lower() == "bar" and n.id != room), None)
    if bar is None:
        others = [n.id for n in topo.tour_nodes() if n.id not in (room, topo.home_id, 0)]
        others = others or [n.id for n in topo.nodes if n.id not in (room, 0)]
        if not others:
            raise MissionScenarioError(f"{topo.source} has no node to deliver to")
        bar = others[-1]
    return room, bar


def _at_fraction(points: np.ndarray, fraction: float) -> tuple[float, float]:
    seg = np.hypot(*np.diff(points, axis=0).T)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    target = fraction * cum[-1]
    i = int(min(np.searchsorted(cum, target, side="right") - 1, len(seg) - 1))
    f = (target - cum[i]) / seg[i] if seg[i] > 0 else 0.0
    p = points[i] + f * (points[i + 1] - points[i])
    return float(p[0]), float(p[1])


def choose_checkpoints(
    topo: TopologicalMap, leg1: list[int], leg2: list[int], start: tuple[float, float]
) -> list[Checkpoint]:
    """P1 on leg 1 (at 1/2), P2 and P3 on leg 2 (at 1/3, 2/3): nodes when there are, else points."""
    out: list[Checkpoint] = []
    for name, leg, fraction, origin in (
        ("P1", leg1, 0.5, start),
        ("P2", leg2, 1 / 3, None),
        ("P3", leg2, 2 / 3, None),
    ):
        first = origin or (topo.node(leg[0]).pose.x, topo.node(leg[0]).pose.y)
        nodes = leg if origin is not None else leg[1:]
        points = np.asarray([first] + [(topo.node(n).pose.x, topo.node(n).pose.y) for n in nodes])
        seg = np.hypot(*np.diff(points, axis=0).T)
        cum = np.concatenate(([0.0], np.cumsum(seg)))
        total = cum[-1] if cum[-1] > 0 else 1.0
        used = {c.node for c in out if c.name != "P1"}  # P2 and P3 share leg 2
        candidates = [
            (abs(cum[k + 1] / total - fraction), nodes[k])
            for k in range(len(nodes) - 1)  # intermediate: not the leg's last node
            if nodes[k] not in used and 0.15 < cum[k + 1] / total < 0.85
        ]
        if candidates:
            node = min(candidates)[1]
            pose = topo.node(node).pose
            out.append(Checkpoint(name, pose.x, pose.y, node))
        else:
            x, y = _at_fraction(points, fraction)
            out.append(Checkpoint(name, x, y, None))
    return out


class HumanDriver:
    """A scripted operator at the Base Station (see the module docstring)."""

    def __init__(self, system: SimulatedSystem, shared: bool) -> None:
        self.system = system
        self.shared = shared
        limits = system.stack.config.planner  # the same limits as autonomy (issue 17)
        self.max_linear = limits.max_linear_speed
        self.max_angular = limits.max_angular_speed
        self._seen: deque[tuple[float, Pose2D | None, LaserScan | None]] = deque()
        self._view: tuple[Pose2D | None, LaserScan | None] = (None, None)
        self._joystick: deque[tuple[float, float, float]] = deque()  # (due, linear, angular)
        config = PlannerConfig()
        self.planner = GlobalPlanner(system.grid, config)
        self.costs = Costmap(system.grid, config).static_costs
        self.path: np.ndarray | None = None
        self._path_target: tuple[float, float] | None = None
        self._planned_at = -math.inf
        self.driving = False  # shared mode: the operator holds the joystick
        self.handovers = 0
        self.teleop_time = 0.0
        self._waiting = 0.0  # [s] standing behind something right ahead

    # -- what the station shows ---------------------------------------------------------------

    def _target(self) -> tuple[Pose2D, bool] | None:
        sup = self.system.supervisor
        route, index = sup.current_route, sup.route_index
        if route is None or index is None or sup.state != SupervisorState.NAVIGATING:
            return None
        index = min(index, len(route.waypoints) - 1)
        return route.waypoints[index], index == len(route.waypoints) - 1

    def _plan(self, now: float, pose: Pose2D, target: Pose2D) -> None:
        key = (target.x, target.y)
        deviated = False
        if self.path is not None:
            deviated = float(np.min(np.hypot(*(self.path - (pose.x, pose.y)).T))) > 1.0
        if self.path is None or key != self._path_target or deviated or now - self._planned_at > 10:
            try:
                points = self.planner.plan(self.costs, (pose.x, pose.y), key)
                self.path = np.asarray(points, dtype=np.float64)
            except PlanningError as exc:
                logger.warning("operator cannot plan to %s: %s", key, exc)
                self.path = np.asarray([(pose.x, pose.y), key], dtype=np.float64)
            self._path_target, self._planned_at = key, now

    def _points(self) -> np.ndarray:
        """The end points of the scan the operator sees, in the robot frame (none: no scan)."""
        scan = self._view[1]
        return scan.points() if scan is not None else np.empty((0, 2))

    def _front_range(self) -> float:
        """Free range [m] straight ahead in the robot's published scan (a 0.7 m wide lane)."""
        pts = self._points()
        if len(pts) == 0:
            return math.inf
        lane = (pts[:, 0] > 0.0) & (np.abs(pts[:, 1]) < 0.35)
        return float(pts[lane, 0].min()) if np.any(lane) else math.inf

    def _side_clearance(self) -> float:
        pts = self._points()
        side = (np.abs(pts[:, 0]) < 0.5) & (np.abs(pts[:, 1]) > 0.0)
        return float(np.abs(pts[side, 1]).min()) if np.any(side) else math.inf

    def _freer_side(self) -> float:
        """+1 if there is more room to the left within 1 m ahead in the scan, else -1."""
        pts = self._points()
        ahead = (pts[:, 0] > -0.2) & (pts[:, 0] < 1.0)
        left = pts[ahead & (pts[:, 1] > 0), 1]
        right = -pts[ahead & (pts[:, 1] < 0), 1]
        room_left = float(left.min()) if left.size else math.inf
        room_right = float(right.min()) if right.size else math.inf
        return 1.0 if room_left >= room_right else -1.0

    def _straight_ahead(self, pose: Pose2D, start: int) -> tuple[float, float]:
        """(length [m] of the path ahead within 20 deg of its first direction, that direction)."""
        path = self.path
        if path is None or start >= len(path) - 1:
            return 0.0, pose.yaw
        first = math.atan2(*(path[min(start + 3, len(path) - 1)] - path[start])[::-1])
        length = 0.0
        for k in range(len(path) - 1 - start):
            step = path[start + k + 1] - path[start + k]
            heading = math.atan2(step[1], step[0])
            if abs(angle_diff(heading, first)) > math.radians(20):
                break
            length += float(np.hypot(*step))
        return length, first

    # -- the 100 ms loop -----------------------------------------------------------------------

    def observe(self, now: float) -> None:
        """What the robot publishes now reaches the operator's eyes PERCEPTION_DELAY later; the
        joystick moves REACTION_TIME after a decision (called after every daemon step)."""
        stack = self.system.stack
        self._seen.append((now, stack.pose, stack.last_scan))
        while self._seen and self._seen[0][0] <= now - PERCEPTION_DELAY + 1e-9:
            _, pose, scan = self._seen.popleft()
            self._view = (pose, scan)
        while self._joystick and self._joystick[0][0] <= now + 1e-9:
            _, linear, angular = self._joystick.popleft()
            stack.on_twist("station_vel", linear, angular, now)

    def _send(self, now: float, linear: float, angular: float) -> None:
        self._joystick.append((now + REACTION_TIME, linear, angular))

    def tick(self, now: float) -> bool:
        system = self.system
        if system.of(TaskFinished):
            return True
        pose = self._view[0]
        target = self._target()
        if pose is None or target is None:
            self._release(now)
            return False
        goal, final = target
        self._plan(now, pose, goal)
        assert self.path is not None
        nearest = int(np.argmin(np.hypot(*(self.path - (pose.x, pose.y)).T)))
        to_goal = math.hypot(goal.x - pose.x, goal.y - pose.y)
        if self.shared:
            straight, direction = self._straight_ahead(pose, nearest)
            aligned = abs(angle_diff(direction, pose.yaw)) < 0.35
            narrow = self._side_clearance() < 0.6
            needed = STRAIGHT_STAY if self.driving else STRAIGHT_ENTER
            wants = straight >= needed and aligned and not narrow and to_goal > GOAL_HANDOVER
            if not wants:
                self._release(now)
                return False
            if not self.driving:
                self.handovers += 1
            self.driving = True
            self.teleop_time += 0.1
        linear, angular = self._pursue(pose, goal, final, nearest, to_goal)
        self._send(now, linear, angular)
        return False

    def _release(self, now: float) -> None:
        if self.driving:
            self._send(now, 0.0, 0.0)  # joystick springs back
        self.driving = False

    def _pursue(
        self, pose: Pose2D, goal: Pose2D, final: bool, nearest: int, to_goal: float
    ) -> tuple[float, float]:
        assert self.path is not None
        cfg = self.system.supervisor.config
        if final and to_goal < 0.6 * cfg.goal_tolerance:
            err = angle_diff(goal.yaw, pose.yaw)  # at the goal: turn to its heading
            if abs(err) < 0.5 * cfg.yaw_tolerance:
                return 0.0, 0.0
            return 0.0, max(-0.5, min(0.5, 1.2 * err))
        rest = self.path[nearest:]
        dist = np.hypot(*(rest - (pose.x, pose.y)).T)
        ahead = np.nonzero(dist >= LOOKAHEAD)[0]
        carrot = rest[ahead[0]] if len(ahead) else rest[-1]
        local = Pose2D(float(carrot[0]), float(carrot[1]), 0.0).relative_to(pose)
        bearing = math.atan2(local.y, local.x)
        if abs(bearing) > 0.8:
            return 0.0, math.copysign(min(self.max_angular, 0.3 + abs(bearing)), bearing)
        l2 = max(local.x**2 + local.y**2, 1e-6)
        curvature = 2.0 * local.y / l2
        v = self.max_linear
        v = min(v, self.max_angular / max(abs(curvature), 1e-6))
        front = self._front_range() - 0.3  # from the laser to the bumper
        v = min(v, self.max_linear * max(0.0, min(1.0, (front - 0.4) / 1.5)))
        if final:
            v = min(v, max(0.08, 0.5 * to_goal))
        w = max(-self.max_angular, min(self.max_angular, v * curvature))
        if v < 0.05 and front < 0.6:
            if abs(bearing) > 0.15:  # a door jamb ahead: square up to the carrot first
                return 0.0, math.copysign(0.4, bearing)
            # Something right ahead: wait for it to move; after WAIT_BEFORE_EVADING s, steer
            # around it on the side with more room, as a person at the joystick would.
            self._waiting += 0.1
            if self._waiting > WAIT_BEFORE_EVADING:
                if self._waiting > WAIT_BEFORE_EVADING + EVADE_S:
                    self._waiting = 0.0
                turn = math.copysign(0.5, self._freer_side())
                return (0.0 if front < 0.3 else 0.08), turn
            return 0.0, 0.0
        self._waiting = 0.0
        return v, w


def run_mode(options: ScenarioOptions, mode: str) -> dict[str, Any]:
    """One mission in ``mode``; returns its figures."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    base = mode.removesuffix("_assisted")
    system = SimulatedSystem(options, start_node=0, autonomy=base != "teleoperation")
    system.stack.set_teleop_assist("station_vel", mode.endswith("_assisted"), system.now)
    system.hooks.append(auto_answer_requests(ACCEPT_AFTER_S))
    system.localise()
    topo = system.topo
    room, bar = mission_nodes(topo)
    start = system.start_pose
    leg1 = system.route_planner.plan(start, room).node_ids
    leg2 = system.route_planner.plan(topo.node(room).pose, bar).node_ids
    leg1_nodes = [n for n in leg1 if n is not None]
    leg2_nodes = [n for n in leg2 if n is not None]
    if leg2_nodes[0] != room:
        leg2_nodes = [room, *leg2_nodes]
    checkpoints = choose_checkpoints(topo, leg1_nodes, leg2_nodes, (start.x, start.y))
    text = f"Please take this to the {topo.node(bar).name}"
    system.apply(system.supervisor.submit(Delivery(text, room, bar)))
    t0 = system.now
    driver = HumanDriver(system, shared=base == "shared") if base != "autonomous" else None
    track: list[tuple[float, float, float]] = []

    def on_step(now: float) -> None:
        if driver is not None:
            driver.observe(now)
        if round(now * 50) % 5 == 0:
            truth = system.sim.true_pose()
            track.append((now, truth.x, truth.y))

    def tick(now: float) -> bool:
        if driver is not None:
            return driver.tick(now)
        return bool(system.of(TaskFinished))

    run_ticks(system, tick, options.max_sim_time, on_step=on_step)
    finished = system.of(TaskFinished)
    ok = bool(finished) and finished[0][1].ok
    t_end = finished[0][0] if finished else system.now
    shown = system.of(RequestShown)
    t_task = shown[0][0] if shown else math.nan
    times = _checkpoint_times(track, checkpoints, t0, t_task, t_end)
    marks = [t0, times["P1"], t_task, times["P2"], times["P3"], t_end]
    legs = ["Start->P1", "P1->Task", "Task->P2", "P2->P3", "P3->End"]
    between = {legs[i]: _round(marks[i + 1] - marks[i]) for i in range(5)}
    figures: dict[str, Any] = {
        "mode": mode,
        "completed": ok,
        "reason": finished[0][1].reason if finished else "time limit reached",
        "duration_s": round(t_end - t0, 1),
        "collisions": system.sim.collisions,
        **system.metrics.figures(),
        "checkpoint_times_s": between,
        "checkpoints": {c.name: c.label(topo) for c in checkpoints},
        "checkpoint_order_ok": all(
            math.isfinite(marks[i]) and marks[i] <= marks[i + 1] for i in range(5)
        ),
        "realtime_factor": round(system.realtime_factor(), 1),
    }
    if driver is not None:
        figures["operator_handovers"] = driver.handovers
        figures["operator_teleop_s"] = round(driver.teleop_time, 1)
        figures["operator_max_linear_mps"] = driver.max_linear
        figures["operator_delay_s"] = PERCEPTION_DELAY + REACTION_TIME
    figures["monitor_interventions"] = system.stack.guard.interventions
    return figures


def _round(value: float) -> float | None:
    return round(value, 3) if math.isfinite(value) else None


def _checkpoint_times(
    track: list[tuple[float, float, float]],
    checkpoints: list[Checkpoint],
    t0: float,
    t_task: float,
    t_end: float,
) -> dict[str, float]:
    """Closest approach of the truth to each checkpoint within its leg window (P3 after P2)."""
    if not track:
        return {c.name: math.nan for c in checkpoints}
    arr = np.asarray(track)
    out: dict[str, float] = {}
    windows = {"P1": (t0, t_task), "P2": (t_task, t_end), "P3": (t_task, t_end)}
    for c in checkpoints:
        lo, hi = windows[c.name]
        if c.name == "P3" and math.isfinite(out.get("P2", math.nan)):
            lo = out["P2"]
        if not (math.isfinite(lo) and math.isfinite(hi)):
            out[c.name] = math.nan
            continue
        mask = (arr[:, 0] >= lo) & (arr[:, 0] <= hi)
        if not np.any(mask):
            out[c.name] = math.nan
            continue
        sub = arr[mask]
        k = int(np.argmin(np.hypot(sub[:, 1] - c.x, sub[:, 2] - c.y)))
        out[c.name] = float(sub[k, 0])
    return out


def _mmss(seconds: float) -> str:
    minutes, secs = divmod(round(seconds), 60)
    return f"{minutes:02d}:{secs:02d}"


def format_tables(results: dict[str, dict[str, Any]]) -> str:
    lines = [
        "Test Scenario 3 (thesis Tables 6.5 and 6.7): localisation and obstacle clearance",
        "Test type               Duration  Collisions  Loc. losses  Min. clearance (cm)      Mean linear",
        "                        (mm:ss)   (#)         (#)          min     max     mean     speed (m/s)",
    ]
    for mode, f in results.items():
        lines.append(
            f"{mode:<23} {_mmss(f['duration_s']):<9} {f['collisions']:<11} "
            f"{f['localisation_losses']:<12} {f['min_clearance_m'] * 100:<7.1f} "
            f"{f['max_clearance_m'] * 100:<7.1f} {f['mean_clearance_m'] * 100:<8.2f} "
            f"{f['mean_speed_mps']:.4f}{'' if f['completed'] else '  (NOT COMPLETED)'}"
        )
    lines += [
        "",
        "Test Scenario 3 (thesis Tables 6.6 and 6.7): time between checkpoints (s)",
        "Test type               Start->P1  P1->Task   Task->P2   P2->P3     P3->End",
    ]
    for mode, f in results.items():
        cells = " ".join(
            f"{'-' if v is None else f'{v:.3f}':<10}" for v in f["checkpoint_times_s"].values()
        )
        lines.append(f"{mode:<23} {cells}")
    first = next(iter(results.values()))
    lines.append("checkpoints: " + "; ".join(f"{v}" for v in first["checkpoints"].values()))
    return "\n".join(lines)


def assistance_effect(results: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """How switching the station's assisted teleoperation on changes each operator mode."""
    out: dict[str, dict[str, Any]] = {}
    for base in ("teleoperation", "shared"):
        off, on = results.get(base), results.get(f"{base}_assisted")
        if off is None or on is None:
            continue
        out[base] = {
            "completed": [off["completed"], on["completed"]],
            "duration_change_s": round(on["duration_s"] - off["duration_s"], 1),
            "collisions": [off["collisions"], on["collisions"]],
            "min_clearance_m": [off["min_clearance_m"], on["min_clearance_m"]],
            "mean_speed_mps": [off["mean_speed_mps"], on["mean_speed_mps"]],
            "monitor_interventions": [off["monitor_interventions"], on["monitor_interventions"]],
        }
    return out


def run(options: ScenarioOptions) -> ScenarioResult:
    results = {mode: run_mode(options, mode) for mode in MODES}
    figures: dict[str, Any] = {
        **results,
        "assistance": assistance_effect(results),
        "seed": options.seed,
        "people": options.people,
    }
    return ScenarioResult("mission", format_tables(results), figures)
