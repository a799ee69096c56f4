"""People walking in the office: circles that patrol routes, pause, yield and sometimes block.

Each person is a disc (radius ~0.25 m, a shoulder-width ellipse seen by a laser at knee to waist
height) walking at 0.8-1.3 m/s along a closed patrol route: a list of waypoints joined by
collision-free paths. Paths are shortest paths on a lattice roadmap (pitch ``lattice`` m) whose
nodes keep at least the person's radius from every wall (``World.clearance``), found with
Dijkstra (``scipy.sparse.csgraph.dijkstra``) and shortened by line-of-sight string pulling, so
people walk along corridors and through doorways but never through walls. Routes are given, or
generated from random well-clear points of the largest free region.

Behaviour per step (a small finite-state machine, deterministic for a seeded Generator):
``walking`` toward the next path point; ``paused`` for 1-4 s at a waypoint (with probability
``pause_probability``); ``yielding`` while the next position would come within
``robot_margin`` of the robot body or into a wall (e.g. a newly added obstacle), unless the move
takes them away from the robot; ``giving_way``: a person who has yielded for ``yield_patience``
and cannot get round the robot by sidestepping (in a doorway, between the robot and a wall; the
sidesteps shuffle in place for another ``yield_patience``) steps back, away from the robot,
until ``give_way_clearance`` from its body, and lets it pass for ``give_way_s`` before walking on,
as people do in a doorway (without it robot and person wait for each other for ever: issue 12);
``blocking``: a person flagged ``blocker`` who finds themselves in
front of the robot (within ``blocker_trigger`` m ahead, within the robot's width plus 0.5 m
sideways) stops there for a few seconds with probability ``blocker_probability`` — the scripted
"someone stands in the robot's way" case of the thesis's navigation tests. People do not avoid
each other (they pass through one another), which keeps them deadlock-free.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import Enum
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from scipy import sparse
from scipy.sparse import csgraph

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.schema import within
from robot_daemon.sim.diff_drive import RobotFootprint
from robot_daemon.sim.world import World

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


class PeopleConfigError(ValueError):
    """A crowd parameter or a patrol route is invalid; the message says which."""


class PersonState(Enum):
    """What a person is doing."""

    WALKING = "walking"
    PAUSED = "paused"
    YIELDING = "yielding"
    GIVING_WAY = "giving_way"  # stepping back out of the robot's way (a doorway stand-off)
    BLOCKING = "blocking"


Probability = Annotated[float, within(0.0, 1.0)]
Seconds = Annotated[float, within(0.0, 600.0, "s")]
Span = tuple[float, float]  # (lo, hi) with 0 <= lo <= hi


class CrowdConfig(schema.Declared, frozen=True):
    """Behaviour parameters shared by all people."""

    ROOT: ClassVar[str] = "CrowdConfig"
    ERROR: ClassVar[type[Exception]] = PeopleConfigError
    radius: Annotated[float, within(0.05, 1.0, "m")] = 0.25
    speed_range: Span = (0.8, 1.3)  # [m/s]
    pause_probability: Probability = 0.3  # at each route waypoint
    pause_range: Span = (1.0, 4.0)  # [s]
    robot_margin: float = 0.3  # [m] keep this far from the robot body
    # [s] a person blocked by the robot waits this long, then sidesteps away from it and walks
    # on (otherwise a person yielding on the robot's goal and the robot waiting for them to
    # leave would wait for each other forever)
    yield_patience: Seconds = 3.0
    # [m] from the robot body, stepping back in a stand-off
    give_way_clearance: Annotated[float, within(0.0, 10.0, "m")] = 1.2
    give_way_s: Seconds = 8.0  # [s] the person lets the robot pass, then walks on
    blocker_probability: Probability = 0.5  # per encounter, for people flagged as blockers
    blocker_trigger: float = 2.5  # [m] ahead of the robot
    blocker_duration: Span = (3.0, 8.0)  # [s]
    blocker_cooldown: float = 15.0  # [s] before the same person blocks again
    lattice: Annotated[float, within(0.05, 1.0, "m")] = 0.2  # roadmap pitch for route planning

    def check(self) -> None:
        for name in ("speed_range", "pause_range", "blocker_duration"):
            lo, hi = getattr(self, name)
            if not 0 <= lo <= hi:
                raise PeopleConfigError(f"CrowdConfig.{name} must be (lo, hi) with 0 <= lo <= hi")


@dataclass
class Person:
    """One walking person (mutable simulation state)."""

    person_id: int
    path: FloatArray  # (N, 2) closed polyline [m]
    waypoint_mask: npt.NDArray[np.bool_]  # path points that are route waypoints
    speed: float  # [m/s]
    radius: float  # [m]
    blocker: bool = False
    x: float = 0.0
    y: float = 0.0
    target: int = 1
    state: PersonState = PersonState.WALKING
    timer: float = 0.0  # [s] left in PAUSED / BLOCKING
    cooldown: float = 0.0  # [s] before blocking again
    heading: float = 0.0  # [rad]
    yielded: float = 0.0  # [s] spent yielding to the robot since the last free step


class Roadmap:
    """A lattice of wall-clear points with 8-connected edges, for shortest walking paths."""

    def __init__(self, world: World, clearance: float, pitch: float) -> None:
        self.world = world
        self.clearance = clearance
        g = world.grid
        w_m, h_m = g.size_m
        xs = g.origin_x + pitch / 2 + pitch * np.arange(max(1, int(w_m / pitch)))
        ys = g.origin_y + pitch / 2 + pitch * np.arange(max(1, int(h_m / pitch)))
        gx, gy = np.meshgrid(xs, ys)
        ok = world.clearance(gx, gy) >= clearance
        self.shape = ok.shape
        node_of = np.full(ok.shape, -1, dtype=np.int64)
        node_of[ok] = np.arange(int(ok.sum()))
        self.xy = np.column_stack((gx[ok], gy[ok]))
        rows, cols = [], []
        weights = []
        rows_h, cols_w = ok.shape
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            # Pairs (r, c) -> (r + dr, c + dc); dr is 0 or 1, dc is -1, 0 or 1.
            a = node_of[: rows_h - dr, max(0, -dc) : cols_w - max(0, dc)]
            b = node_of[dr:, max(0, dc) : cols_w + min(0, dc)]
            both = (a >= 0) & (b >= 0)
            ia, ib = a[both], b[both]
            mid = 0.5 * (self.xy[ia] + self.xy[ib])
            good = world.clearance(mid[:, 0], mid[:, 1]) >= clearance
            rows.append(ia[good])
            cols.append(ib[good])
            weights.append(np.full(int(good.sum()), pitch * math.hypot(dr, dc)))
        n = len(self.xy)
        r = np.concatenate(rows) if rows else np.empty(0, dtype=np.int64)
        c = np.concatenate(cols) if cols else np.empty(0, dtype=np.int64)
        wt = np.concatenate(weights) if weights else np.empty(0)
        self.graph = sparse.csr_matrix((wt, (r, c)), shape=(n, n))
        if n:
            _, self.component = csgraph.connected_components(self.graph, directed=False)
        else:
            self.component = np.empty(0, dtype=np.int32)
        logger.debug("roadmap: %d nodes, %d edges", n, len(wt))

    def nearest(self, x: float, y: float) -> int:
        """Index of the roadmap node nearest to a point."""
        if not len(self.xy):
            raise PeopleConfigError(f"{self.world.grid.source}: no space wide enough for people")
        return int(np.argmin(np.hypot(self.xy[:, 0] - x, self.xy[:, 1] - y)))

    def visible(self, a: FloatArray, b: FloatArray) -> bool:
        """True if the straight segment a-b keeps the roadmap clearance from walls."""
        n = max(2, math.ceil(float(np.hypot(*(b - a))) / (self.world.resolution / 2)) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        pts = a + s * (b - a)
        return bool((self.world.clearance(pts[:, 0], pts[:, 1]) >= self.clearance).all())

    def path(self, start: tuple[float, float], goal: tuple[float, float]) -> FloatArray:
        """Shortest wall-clear polyline from start to goal (both snapped to the roadmap)."""
        i, j = self.nearest(*start), self.nearest(*goal)
        if self.component[i] != self.component[j]:
            raise PeopleConfigError(
                f"{self.world.grid.source}: no walkable path from {start} to {goal}"
            )
        _, pred = csgraph.dijkstra(self.graph, directed=False, indices=i, return_predecessors=True)
        nodes = [j]
        while nodes[-1] != i:
            nodes.append(int(pred[nodes[-1]]))
        pts = self.xy[nodes[::-1]]
        return self._string_pull(pts)

    def _string_pull(self, pts: FloatArray) -> FloatArray:
        out = [pts[0]]
        i = 0
        while i < len(pts) - 1:
            j = len(pts) - 1
            while j > i + 1 and not self.visible(pts[i], pts[j]):
                j = i + 1 + (j - i - 1) // 2 if j - i > 8 else j - 1
            out.append(pts[j])
            i = j
        return np.array(out)


class Crowd:
    """All simulated people; step them with the robot's true pose and footprint."""

    def __init__(
        self, world: World, rng: np.random.Generator, config: CrowdConfig | None = None
    ) -> None:
        self.world = world
        self.config = config or CrowdConfig()
        self._rng = rng
        self.people: list[Person] = []  # in creation order
        self._next_id = 0
        self._roadmap: Roadmap | None = None
        self._roadmap_version = -1

    def roadmap(self) -> Roadmap:
        """The walking roadmap for the current walls (rebuilt after an obstacle is added)."""
        if self._roadmap is None or self._roadmap_version != self.world.version:
            self._roadmap = Roadmap(self.world, self.config.radius + 0.05, self.config.lattice)
            self._roadmap_version = self.world.version
        return self._roadmap

    def circles(self) -> FloatArray:
        """(N, 3) rows of x [m], y [m], radius [m]."""
        if not self.people:
            return np.empty((0, 3))
        return np.array([(p.x, p.y, p.radius) for p in self.people], dtype=np.float64)

    def add_person(
        self,
        route: list[tuple[float, float]],
        *,
        blocker: bool = False,
        speed: float | None = None,
    ) -> int:
        """Add a person patrolling ``route`` (>= 2 waypoints [m], closed loop); return its id."""
        if len(route) < 2:
            raise PeopleConfigError("a patrol route needs at least 2 waypoints")
        roadmap = self.roadmap()
        legs: list[FloatArray] = []
        marks: list[npt.NDArray[np.bool_]] = []
        for a, b in zip(route, [*route[1:], route[0]], strict=True):
            leg = roadmap.path(a, b)[:-1]
            legs.append(leg)
            mark = np.zeros(len(leg), dtype=bool)
            mark[0] = True
            marks.append(mark)
        path = np.vstack(legs)
        lo, hi = self.config.speed_range
        person = Person(
            person_id=self._next_id,
            path=path,
            waypoint_mask=np.concatenate(marks),
            speed=float(speed if speed is not None else self._rng.uniform(lo, hi)),
            radius=self.config.radius,
            blocker=blocker,
            x=float(path[0, 0]),
            y=float(path[0, 1]),
            target=1 % len(path),
        )
        self.people.append(person)
        self._next_id += 1
        return person.person_id

    def random_route(
        self, n_waypoints: int = 4, min_clearance: float = 0.6
    ) -> list[tuple[float, float]]:
        """Waypoints at well-clear points of the largest walkable region (spread apart)."""
        roadmap = self.roadmap()
        if not len(roadmap.xy):
            raise PeopleConfigError(f"{self.world.grid.source}: no space wide enough for people")
        counts = np.bincount(roadmap.component)
        in_main = roadmap.component == int(counts.argmax())
        clear = self.world.clearance(roadmap.xy[:, 0], roadmap.xy[:, 1]) >= min_clearance
        candidates = np.flatnonzero(in_main & clear)
        if candidates.size == 0:
            candidates = np.flatnonzero(in_main)
        picks = self._rng.choice(
            candidates, size=n_waypoints, replace=candidates.size < n_waypoints
        )
        return [(float(roadmap.xy[k, 0]), float(roadmap.xy[k, 1])) for k in picks]

    def spawn(
        self,
        n: int,
        n_waypoints: int = 4,
        blocker_fraction: float = 0.3,
        robot: tuple[Pose2D, RobotFootprint] | None = None,
    ) -> None:
        """Add ``n`` people on generated routes; about ``blocker_fraction`` of them block.

        Nobody starts inside or against the ``robot`` (its start pose and footprint): a person
        whose first waypoint lies within ``radius + robot_margin`` of its body starts at the
        first waypoint of their patrol that does not (the same closed route, entered
        elsewhere; no extra random draws, so every other person is as before). Willow seed 7
        put a person 0.23 m from the robot's centre, inside its body, at the start.
        """
        for _ in range(n):
            route = self.random_route(n_waypoints)
            if robot is not None:
                route = self._start_clear_of(route, *robot)
            self.add_person(route, blocker=bool(self._rng.random() < blocker_fraction))

    def _start_clear_of(
        self, route: list[tuple[float, float]], pose: Pose2D, footprint: RobotFootprint
    ) -> list[tuple[float, float]]:
        """``route`` rotated to start at its first waypoint clear of the robot's body."""
        keep = self.config.radius + self.config.robot_margin
        for k, (x, y) in enumerate(route):
            if footprint.distance_to_point(pose, x, y) >= keep:
                return route[k:] + route[:k]
        raise PeopleConfigError(
            f"every waypoint of a patrol route lies within {keep:.2f} m of the robot at {pose}"
        )

    # --- stepping ---------------------------------------------------------------------------

    def step(self, dt: float, robot_pose: Pose2D, footprint: RobotFootprint) -> None:
        """Advance every person by dt [s] given the robot's true pose."""
        for p in self.people:
            self._step_person(p, dt, robot_pose, footprint)

    def _in_front_of_robot(self, p: Person, robot_pose: Pose2D, footprint: RobotFootprint) -> bool:
        c, s = math.cos(robot_pose.yaw), math.sin(robot_pose.yaw)
        dx, dy = p.x - robot_pose.x, p.y - robot_pose.y
        local_x, local_y = c * dx + s * dy, -s * dx + c * dy
        ahead = footprint.offset_x + footprint.length / 2
        return (
            ahead < local_x < ahead + self.config.blocker_trigger
            and abs(local_y - footprint.offset_y) < footprint.width / 2 + 0.5
        )

    def _step_person(
        self, p: Person, dt: float, robot_pose: Pose2D, footprint: RobotFootprint
    ) -> None:
        cfg = self.config
        p.cooldown = max(0.0, p.cooldown - dt)
        if p.state is PersonState.GIVING_WAY:
            p.timer -= dt
            if p.timer > 0:
                self._step_back(p, p.speed * dt, robot_pose, footprint)
                return
            p.state = PersonState.WALKING
        if p.state in (PersonState.PAUSED, PersonState.BLOCKING):
            p.timer -= dt
            if p.timer > 0:
                return
            if p.state is PersonState.BLOCKING:
                p.cooldown = cfg.blocker_cooldown
            p.state = PersonState.WALKING
        if p.blocker and p.cooldown <= 0 and self._in_front_of_robot(p, robot_pose, footprint):
            p.cooldown = cfg.blocker_cooldown
            if self._rng.random() < cfg.blocker_probability:
                p.state = PersonState.BLOCKING
                p.timer = float(self._rng.uniform(*cfg.blocker_duration))
                logger.debug("person %d blocks the robot for %.1f s", p.person_id, p.timer)
                return
        tx, ty = p.path[p.target]
        dx, dy = tx - p.x, ty - p.y
        dist = math.hypot(dx, dy)
        step = p.speed * dt
        if dist <= step:
            nx, ny = float(tx), float(ty)
        else:
            nx, ny = p.x + dx / dist * step, p.y + dy / dist * step
        if not self._move_allowed(p, nx, ny, robot_pose, footprint):
            p.yielded += dt
            if p.yielded < cfg.yield_patience:
                p.state = PersonState.YIELDING
            elif p.yielded >= 2.0 * cfg.yield_patience or not self._sidestep(
                p, dx, dy, dist, step, robot_pose, footprint
            ):
                # No way round the robot (a doorway: sidesteps that only shuffle in place for
                # another yield_patience): step back and let it pass.
                p.state = PersonState.GIVING_WAY
                p.timer = cfg.give_way_s
                p.yielded = 0.0
                logger.debug("person %d gives way to the robot", p.person_id)
            return
        if footprint.distance_to_point(robot_pose, nx, ny) > p.radius + cfg.robot_margin + 0.25:
            p.yielded = 0.0  # clear of the robot: patience restored
        p.state = PersonState.WALKING
        if dist > 1e-9:
            p.heading = math.atan2(dy, dx)
        p.x, p.y = nx, ny
        if dist <= step:
            reached = p.target
            p.target = (p.target + 1) % len(p.path)
            if p.waypoint_mask[reached] and self._rng.random() < cfg.pause_probability:
                p.state = PersonState.PAUSED
                p.timer = float(self._rng.uniform(*cfg.pause_range))

    def _sidestep(
        self,
        p: Person,
        dx: float,
        dy: float,
        dist: float,
        step: float,
        robot_pose: Pose2D,
        footprint: RobotFootprint,
    ) -> bool:
        """Walk around the robot: a step tangent to it and slightly outward, on the side that
        leads towards the walking target first; True if the person moved."""
        ax, ay = p.x - robot_pose.x, p.y - robot_pose.y
        norm = math.hypot(ax, ay)
        if norm <= 1e-9:
            return False
        ax, ay = ax / norm, ay / norm
        tangents = [(-ay, ax), (ay, -ax)]
        tangents.sort(key=lambda t: -(t[0] * dx + t[1] * dy))
        for tx, ty in tangents:
            ux, uy = 0.9 * tx + 0.45 * ax, 0.9 * ty + 0.45 * ay
            scale = step / math.hypot(ux, uy)
            nx, ny = p.x + ux * scale, p.y + uy * scale
            if self._move_allowed(p, nx, ny, robot_pose, footprint):
                p.x, p.y = nx, ny
                p.heading = math.atan2(uy, ux)
                p.state = PersonState.WALKING
                return True
        return False

    def _step_back(
        self, p: Person, step: float, robot_pose: Pose2D, footprint: RobotFootprint
    ) -> None:
        """One step away from the robot while nearer than ``give_way_clearance`` to its body:
        straight away from it, else up to 90 degrees to either side (out of a doorway, along a
        wall); stands still where no such step keeps clear of walls."""
        cfg = self.config
        here = footprint.distance_to_point(robot_pose, p.x, p.y)
        if here >= p.radius + cfg.give_way_clearance:
            return
        away = math.atan2(p.y - robot_pose.y, p.x - robot_pose.x)
        for turn in (0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5):
            nx = p.x + step * math.cos(away + turn)
            ny = p.y + step * math.sin(away + turn)
            if self.world.clearance_at(nx, ny) < p.radius:
                continue
            if footprint.distance_to_point(robot_pose, nx, ny) <= here:
                continue
            p.x, p.y = nx, ny
            p.heading = away + turn + math.pi  # walking backwards, facing the robot
            return

    def _move_allowed(
        self, p: Person, nx: float, ny: float, robot_pose: Pose2D, footprint: RobotFootprint
    ) -> bool:
        if self.world.clearance_at(nx, ny) < p.radius:
            return False
        d_new = footprint.distance_to_point(robot_pose, nx, ny)
        if d_new >= p.radius + self.config.robot_margin:
            return True
        return d_new > footprint.distance_to_point(robot_pose, p.x, p.y)
