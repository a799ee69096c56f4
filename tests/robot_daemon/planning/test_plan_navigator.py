"""Navigator in closed loop: a kinematic robot, a ray-cast laser and synthetic maps.

The loop integrates (v, w) exactly over each 0.1 s step; scans are cast in the *true* world,
which may hold obstacles the navigator's a-priori map lacks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D, wrap_angle
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.planning.config import PlannerConfig, PlannerConfigError
from robot_daemon.planning.navigator import NavCommand, Navigator, NavState

RES = 0.05
DT = 0.1
BEAMS = 271  # 1 degree over 270 degrees: enough for tests, cheap to cast


def two_rooms(door_cells: int = 18) -> OccupancyGrid:
    """8 x 5 m, outer walls, a wall at x = 4 m with a door centred at y = 2.5 m (18 cells: 0.9 m)."""
    cells = np.full((100, 160), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = OCCUPIED
    cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[:, 80:82] = OCCUPIED
    cells[50 - door_cells // 2 : 50 - door_cells // 2 + door_cells, 80:82] = FREE
    return OccupancyGrid(cells, RES, 0.0, 0.0, source="two_rooms")


def corridor() -> OccupancyGrid:
    """10 x 3 m room with a 1.2 m wide, 5 m long corridor in the middle leading to a room."""
    cells = np.full((60, 200), OCCUPIED, dtype=np.int8)
    cells[2:-2, 2:60] = FREE  # west room, 2.8 m wide
    cells[18:42, 60:160] = FREE  # corridor y 0.9..2.1
    cells[2:-2, 160:198] = FREE  # east room
    return OccupancyGrid(cells, RES, 0.0, 0.0, source="corridor")


def with_box(grid: OccupancyGrid, x0: float, y0: float, x1: float, y1: float) -> OccupancyGrid:
    cells = grid.cells.copy()
    r0, c0 = grid.world_to_cell(x0, y0)
    r1, c1 = grid.world_to_cell(x1, y1)
    cells[int(r0) : int(r1) + 1, int(c0) : int(c1) + 1] = OCCUPIED
    return grid.with_cells(cells)


def cast_scan(world: OccupancyGrid, pose: Pose2D, now: float, max_range: float = 8.0) -> LaserScan:
    """Vectorised ray casting: march every beam in half-cell steps to the first blocked cell."""
    angles = np.linspace(-0.75 * math.pi, 0.75 * math.pi, BEAMS)
    t = np.arange(0.0, max_range, 0.5 * RES)
    xs = pose.x + np.cos(angles + pose.yaw)[:, None] * t[None, :]
    ys = pose.y + np.sin(angles + pose.yaw)[:, None] * t[None, :]
    rows, cols = world.world_to_cell(xs, ys)
    inside = world.in_bounds(rows, cols)
    hit = np.ones(xs.shape, dtype=bool)
    hit[inside] = world.blocked()[rows[inside], cols[inside]]
    first = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
    ranges = np.where(first >= 0, t[np.maximum(first, 0)], np.inf).astype(np.float32)
    return LaserScan(now, float(angles[0]), float(angles[1] - angles[0]), 0.05, max_range, ranges)


def integrate(pose: Pose2D, v: float, w: float, dt: float = DT) -> Pose2D:
    if abs(w) < 1e-12:
        delta = Pose2D(v * dt, 0.0, 0.0)
    else:
        delta = Pose2D(v / w * math.sin(w * dt), v / w * (1.0 - math.cos(w * dt)), w * dt)
    return pose.compose(delta)


def footprint_clearance(world: OccupancyGrid, pose: Pose2D) -> float:
    """Exact clearance [m] of the 0.60 x 0.55 m rectangle to blocked cell centres nearby."""
    r, c = world.world_to_cell(pose.x, pose.y)
    k = 20
    rows, cols = np.nonzero(world.blocked()[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1])
    if rows.size == 0:
        return math.inf
    x, y = world.cell_to_world(rows + max(r - k, 0), cols + max(c - k, 0))
    cy, sy = math.cos(pose.yaw), math.sin(pose.yaw)
    lx = cy * (x - pose.x) + sy * (y - pose.y)
    ly = -sy * (x - pose.x) + cy * (y - pose.y)
    gap = np.hypot(np.maximum(np.abs(lx) - 0.30, 0.0), np.maximum(np.abs(ly) - 0.275, 0.0))
    return float(gap.min()) - 0.5 * RES  # cell half-size


def run(
    nav: Navigator,
    world: OccupancyGrid,
    pose: Pose2D,
    seconds: float,
    now: float = 0.0,
    until: set[NavState] | None = None,
    move: bool = True,
) -> tuple[Pose2D, list[NavCommand], list[Pose2D], float]:
    until = until if until is not None else {NavState.SUCCEEDED, NavState.BLOCKED}
    commands: list[NavCommand] = []
    poses = [pose]
    for _ in range(round(seconds / DT)):
        cmd = nav.update(now, pose, cast_scan(world, pose, now))
        commands.append(cmd)
        if move:
            pose = integrate(pose, cmd.linear, cmd.angular)
        poses.append(pose)
        now += DT
        if cmd.state in until:
            break
    return pose, commands, poses, now


def check_limits(commands: list[NavCommand], config: PlannerConfig) -> None:
    v = np.array([c.linear for c in commands])
    w = np.array([c.angular for c in commands])
    assert v.max() <= config.max_linear_speed + 1e-9
    assert np.abs(w).max() <= config.max_angular_speed + 1e-9
    assert np.abs(np.diff(np.r_[0.0, v])).max() <= config.linear_acceleration * DT + 1e-9
    assert np.abs(np.diff(np.r_[0.0, w])).max() <= config.angular_acceleration * DT + 1e-9


def test_reaches_a_goal_through_a_door() -> None:
    grid = two_rooms()
    nav = Navigator(grid)
    assert nav.state is NavState.IDLE
    nav.set_route([Pose2D(6.5, 3.5, math.pi / 2)], now=0.0)
    assert nav.state is NavState.PLANNING
    pose, commands, poses, _ = run(nav, grid, Pose2D(1.0, 1.0, 0.0), 80.0)
    states = [c.state for c in commands]
    assert states[-1] is NavState.SUCCEEDED, commands[-1]
    assert NavState.FOLLOWING in states and NavState.ROTATING in states
    assert NavState.RECOVERING not in states
    assert math.hypot(pose.x - 6.5, pose.y - 3.5) <= 0.5
    assert abs(wrap_angle(pose.yaw - math.pi / 2)) <= 0.1
    assert min(footprint_clearance(grid, p) for p in poses) > 0.0
    assert commands[-1].linear == 0.0 and commands[-1].angular == 0.0
    check_limits(commands, nav.config)
    # Stays put once succeeded.
    assert nav.update(100.0, pose).state is NavState.SUCCEEDED


def test_route_advances_through_intermediate_goals() -> None:
    grid = two_rooms()
    nav = Navigator(grid)
    route = [Pose2D(2.5, 2.5, 0.0), Pose2D(5.0, 2.5, 0.0), Pose2D(6.0, 1.5, -math.pi / 2)]
    nav.set_route(route, approach_tolerance=0.7, goal_xy_tol=0.3, goal_yaw_tol=0.05, now=0.0)
    pose, commands, _, _ = run(nav, grid, Pose2D(1.0, 2.5, 0.0), 60.0)
    assert commands[-1].state is NavState.SUCCEEDED
    indices = [c.goal_index for c in commands]
    assert indices == sorted(indices) and set(indices) == {0, 1, 2}
    assert math.hypot(pose.x - 6.0, pose.y - 1.5) <= 0.3
    assert abs(wrap_angle(pose.yaw + math.pi / 2)) <= 0.05


def test_replans_around_a_new_obstacle() -> None:
    grid = two_rooms()
    world = with_box(grid, 2.0, 1.6, 2.6, 3.4)  # a cabinet the map does not know
    nav = Navigator(grid)
    nav.set_route([Pose2D(3.4, 2.5, 0.0)], now=0.0)
    _pose, commands, poses, _ = run(nav, world, Pose2D(0.8, 2.5, 0.0), 70.0)
    assert commands[-1].state is NavState.SUCCEEDED, commands[-1]
    assert min(footprint_clearance(world, p) for p in poses) > 0.0
    assert max(abs(p.y - 2.5) for p in poses) > 0.9  # it drove around the cabinet


def test_initial_path_is_replaced_when_the_obstacle_is_seen() -> None:
    grid = two_rooms()
    world = with_box(grid, 2.0, 1.6, 2.6, 3.4)
    nav = Navigator(grid)
    nav.set_route([Pose2D(3.4, 2.5, 0.0)], now=0.0)
    pose = Pose2D(0.8, 2.5, 0.0)
    nav.update(0.0, pose)  # no scan yet: plans on the a-priori map only
    straight = np.asarray(nav.path)
    assert np.abs(straight[:, 1] - 2.5).max() < 0.05
    nav.update(1.0, pose, cast_scan(world, pose, 1.0))  # 1 s later the replan sees the box
    around = np.asarray(nav.path)
    assert np.abs(around[:, 1] - 2.5).max() > 0.9


def test_reports_blocked_in_a_dead_end_after_recoveries() -> None:
    grid = corridor()
    world = with_box(grid, 7.5, 0.9, 7.8, 2.1)  # a trolley closes the far end of the corridor
    config = PlannerConfig(blocked_timeout=15.0, wait_duration=2.0)
    nav = Navigator(grid, config)
    nav.set_route([Pose2D(9.0, 1.5, 0.0)], now=0.0)
    pose, commands, poses, now = run(nav, world, Pose2D(1.0, 1.5, 0.0), 90.0)
    states = [c.state for c in commands]
    assert states[-1] is NavState.BLOCKED, commands[-1]
    assert NavState.RECOVERING in states
    reasons = " ".join(c.reason for c in commands)
    for behaviour in ("clear_costmap", "spin", "back_up", "wait"):
        assert behaviour in reasons
    assert "no path" in commands[-1].reason and "15 s" in commands[-1].reason
    # Where and why: the robot's position, its goal, and the obstacle in front (the trolley).
    where = commands[-1].reason
    assert f"at ({pose.x:.2f}, {pose.y:.2f})" in where and "(9.00, 1.50)" in where
    assert "nearest obstacle seen" in where and "map's nearest wall" in where
    assert min(footprint_clearance(world, p) for p in poses) > 0.0
    assert max(p.x for p in poses) > 3.5  # it drove into the corridor before seeing the trolley
    assert pose.x < 7.5 - 0.3
    # Blocked is terminal until a new goal: zero commands, no oscillation.
    later = [nav.update(now + i * DT, pose, cast_scan(world, pose, now)) for i in range(5)]
    assert all(c.state is NavState.BLOCKED and c.linear == c.angular == 0.0 for c in later)


def test_goal_inside_a_wall_is_blocked_at_once() -> None:
    grid = two_rooms()
    nav = Navigator(grid)
    nav.set_route([Pose2D(4.05, 1.0, 0.0)], now=0.0)
    cmd = nav.update(0.0, Pose2D(1.0, 1.0, 0.0))
    assert cmd.state is NavState.BLOCKED
    assert "unreachable" in cmd.reason and "two_rooms" in cmd.reason


def test_a_door_too_narrow_is_reported_with_where_and_how_wide() -> None:
    """A 0.6 m door for a 0.55 m robot: blocked at once, naming the door's place and width."""
    grid = two_rooms(door_cells=12)
    nav = Navigator(grid)
    nav.set_route([Pose2D(6.5, 2.5, 0.0)], now=0.0)
    cmd = nav.update(0.0, Pose2D(1.0, 2.5, 0.0))
    assert cmd.state is NavState.BLOCKED and cmd.linear == cmd.angular == 0.0
    assert "unreachable" in cmd.reason
    assert "narrows to 0.55-0.60 m at (4.0" in cmd.reason, cmd.reason
    assert "robot 0.55 m wide" in cmd.reason
    # The same door at 0.9 m is planned through.
    wide = Navigator(two_rooms())
    wide.set_route([Pose2D(6.5, 2.5, 0.0)], now=0.0)
    assert wide.update(0.0, Pose2D(1.0, 2.5, 0.0)).state is NavState.FOLLOWING


def test_progress_checker_starts_recovery_when_the_robot_does_not_move() -> None:
    grid = two_rooms()
    nav = Navigator(grid)
    nav.set_route([Pose2D(3.0, 1.0, 0.0)], now=0.0)
    # The wheels slip: commands have no effect.
    _, commands, _, _ = run(nav, grid, Pose2D(1.0, 1.0, 0.0), 11.0, until=set(), move=False)
    first = next(
        i for i, c in enumerate(commands) if c.state is NavState.RECOVERING or "clear" in c.reason
    )
    assert 9.9 <= first * DT <= 10.5
    assert "progress" in commands[first].reason


def test_cancel_and_reconfigure() -> None:
    grid = two_rooms()
    nav = Navigator(grid)
    nav.set_route([Pose2D(3.0, 1.0, 0.0)], now=0.0)
    nav.reconfigure(max_linear_speed=0.1)
    _, commands, _, now = run(nav, grid, Pose2D(1.0, 1.0, 0.0), 5.0)
    assert max(c.linear for c in commands) == pytest.approx(0.1)
    nav.cancel()
    cmd = nav.update(now, Pose2D(1.0, 1.0, 0.0))
    assert (cmd.linear, cmd.angular, cmd.state) == (0.0, 0.0, NavState.IDLE)
    with pytest.raises(PlannerConfigError, match="max_linear_speed"):
        nav.reconfigure(max_linear_speed=-1.0)
    with pytest.raises(PlannerConfigError, match="unknown"):
        nav.reconfigure(max_speed=1.0)
    assert nav.config.max_linear_speed == 0.1


def test_defaults_are_the_thesis_values() -> None:
    config = PlannerConfig()
    assert (config.max_linear_speed, config.max_angular_speed) == (0.25, 1.0)
    assert (config.goal_xy_tolerance, config.goal_yaw_tolerance) == (0.5, 0.1)
    assert config.min_linear_speed == 0.0
    with pytest.raises(PlannerConfigError, match="goal_yaw_tolerance"):
        PlannerConfig(goal_yaw_tolerance=4.0)
    with pytest.raises(PlannerConfigError, match="inflation_radius"):
        PlannerConfig(inflation_radius=0.2)


def test_route_tolerances_are_checked_as_the_route_message_declares_them() -> None:
    nav = Navigator(two_rooms())
    goal = [Pose2D(6.0, 2.5, 0.0)]
    cases = (
        ({"approach_tolerance": 0.0}, r"set_route\.approach_tolerance = 0\.0 m is outside"),
        ({"goal_xy_tol": math.nan}, r"set_route\.goal_xy_tol must be a finite number \[m\]"),
        ({"goal_yaw_tol": 4.0}, r"set_route\.goal_yaw_tol = 4\.0 rad is outside the allowed"),
    )
    for arguments, message in cases:
        with pytest.raises(PlannerConfigError, match=message):
            nav.set_route(goal, now=0.0, **arguments)
        assert nav.state is NavState.IDLE  # a refused route changes nothing
    nav.set_route(goal, approach_tolerance=1, goal_xy_tol=0.3, now=0.0)
    assert nav.state is NavState.PLANNING


def _edge_behind(nav: Navigator, grid: OccupancyGrid, xs: list[float]) -> list[NavCommand]:
    """Feed the robot at x (corridor centre line, facing east) with someone standing 0.7 m ahead
    across the corridor, one 0.1 s step per x: the robot's motion is imposed, not integrated."""
    commands = []
    for i, x in enumerate(xs):
        now = i * DT
        pose = Pose2D(x, 1.5, 0.0)
        world = with_box(grid, x + 0.7, 0.9, x + 0.95, 2.1)
        commands.append(nav.update(now, pose, cast_scan(world, pose, now)))
    return commands


def test_edging_forward_behind_people_is_not_reported_blocked() -> None:
    """Issue 12 (Fetch seed 1): people in a doorway step aside in turn and the robot edges
    through, 0.6 m in 36 s; every 10 s progress window failed, but the recoveries were getting it
    on. Slower than the progress checker's 0.5 m per 10 s yet 2 m on in 60 s: not blocked."""
    grid = corridor()
    nav = Navigator(grid, PlannerConfig(blocked_timeout=15.0, wait_duration=2.0))
    nav.set_route([Pose2D(9.0, 1.5, 0.0)], now=0.0)
    commands = _edge_behind(nav, grid, [3.0 + 0.035 * i * DT for i in range(600)])
    states = [c.state for c in commands]
    assert NavState.RECOVERING in states  # it did need the recoveries
    assert NavState.BLOCKED not in states, next(c.reason for c in commands if c.state == "blocked")


def test_shuttling_without_getting_nearer_is_still_blocked() -> None:
    """Moving is not progress: a robot that shuttles 0.8 m back and forth in front of an
    obstacle is no nearer its goal, and the recovery episode runs out as before."""
    grid = corridor()
    nav = Navigator(grid, PlannerConfig(blocked_timeout=15.0, wait_duration=2.0))
    nav.set_route([Pose2D(9.0, 1.5, 0.0)], now=0.0)
    xs = [3.0 + 0.4 * (1.0 - math.cos(2.0 * math.pi * i * DT / 13.0)) for i in range(600)]
    commands = _edge_behind(nav, grid, xs)
    assert commands[-1].state is NavState.BLOCKED, commands[-1]
    assert "recoveries made no progress for 15 s" in commands[-1].reason


def ring() -> OccupancyGrid:
    """12 x 5 m: two 1.3 m corridors (y 0.1..1.4 and 3.6..4.9) joined at both ends round a block
    of rooms (x 2..10, y 1.4..3.6): from one end of a corridor to the other, 6 m along it or 17 m
    round the block."""
    cells = np.full((100, 240), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = OCCUPIED
    cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[28:72, 40:200] = OCCUPIED
    return OccupancyGrid(cells, RES, 0.0, 0.0, source="ring")


def _pass_someone(stands_for: float) -> tuple[list[NavCommand], list[Pose2D]]:
    """The robot at (3, 0.75) facing east, goal (9, 0.75) down the south corridor; someone stands
    in the corridor at x = 5.5 for ``stands_for`` seconds, then is gone."""
    grid = ring()
    person = with_box(grid, 5.3, 0.5, 5.7, 1.0)  # 1.3 m corridor: 0.4 m either side
    nav = Navigator(grid)
    nav.set_route([Pose2D(9.0, 0.75, 0.0)], now=0.0)
    pose, now = Pose2D(3.0, 0.75, 0.0), 0.0
    commands, poses = [], [pose]
    for _ in range(2500):
        world = person if now < stands_for else grid
        cmd = nav.update(now, pose, cast_scan(world, pose, now))
        commands.append(cmd)
        pose = integrate(pose, cmd.linear, cmd.angular)
        poses.append(pose)
        now += DT
        if cmd.state in (NavState.SUCCEEDED, NavState.BLOCKED):
            break
    return commands, poses


def test_waits_for_someone_in_a_corridor_instead_of_going_round_the_building() -> None:
    """Issue 12 (Willow seeds 6 and 8): a person in a 1.4 m corridor closed it in the costmap and
    the planner sent the robot 15 m round the building; it turned round in the corridor as people
    stepped in and out, until blocked. A blockage is waited for (as long as the detour's extra
    length would take, at most the progress timeout) before a detour is taken."""
    commands, poses = _pass_someone(stands_for=6.0)
    assert commands[-1].state is NavState.SUCCEEDED, commands[-1]
    assert any("waiting for the way ahead to clear" in c.reason for c in commands)
    assert max(p.y for p in poses) < 1.4  # never left the south corridor
    assert min(p.x for p in poses) > 2.9  # never turned back
    assert max(abs(wrap_angle(p.yaw)) for p in poses) < math.pi / 2  # nor round
    assert min(footprint_clearance(ring(), p) for p in poses) > 0.0


def test_a_blockage_that_stays_is_driven_round_after_the_wait() -> None:
    """Someone who does not move: after the wait (at most the progress timeout), the detour."""
    commands, poses = _pass_someone(stands_for=math.inf)
    assert commands[-1].state is NavState.SUCCEEDED, commands[-1]
    waiting = [i for i, c in enumerate(commands) if "waiting for the way" in c.reason]
    assert waiting
    # It edged up to the person (every 0.5 m on restarts the patience, the last creeping 0.5 m
    # too), then waited about the progress timeout, not the 60 s the 15 m detour would take.
    end = poses[waiting[-1]]
    stopped = max(i for i in waiting if poses[i].distance_to(end) >= 0.5)
    assert (waiting[-1] - stopped) * DT <= 2.0 * PlannerConfig().progress_timeout
    assert max(p.y for p in poses) > 3.6  # round the block, by the north corridor
    assert NavState.BLOCKED not in [c.state for c in commands]
