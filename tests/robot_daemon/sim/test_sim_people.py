"""People: stay in free space, follow routes through doorways, yield to and block the robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid, load_map
from robot_daemon.sim.diff_drive import RobotFootprint
from robot_daemon.sim.people import Crowd, CrowdConfig, PeopleConfigError, PersonState
from robot_daemon.sim.world import World

FAR_AWAY = Pose2D(-100.0, -100.0, 0.0)
FP = RobotFootprint()


def two_rooms() -> World:
    """Two 5 x 4 m rooms side by side joined by a 1 m doorway at y 1.5-2.5 (0.05 m cells)."""
    cells = np.full((80, 200), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[:, 99:101] = OCCUPIED
    cells[30:50, 99:101] = FREE
    return World(OccupancyGrid(cells, 0.05, 0.0, 0.0))


def run(crowd: Crowd, world: World, seconds: float, robot: Pose2D = FAR_AWAY) -> float:
    """Step the crowd; return the smallest wall clearance minus radius seen (must be >= 0)."""
    worst = np.inf
    for _ in range(int(seconds / 0.05)):
        crowd.step(0.05, robot, FP)
        c = crowd.circles()
        worst = min(worst, float((world.clearance(c[:, 0], c[:, 1]) - c[:, 2]).min()))
    return worst


def test_person_walks_through_the_doorway_without_touching_walls() -> None:
    world = two_rooms()
    crowd = Crowd(world, np.random.default_rng(0), CrowdConfig(pause_probability=0.0))
    pid = crowd.add_person([(2.0, 3.5), (8.0, 0.6)], speed=1.0)
    xs = []
    for _ in range(300):
        crowd.step(0.05, FAR_AWAY, FP)
        xs.append(crowd.people[pid].x)
        c = crowd.circles()
        assert float(world.clearance(c[0, 0], c[0, 1])) >= 0.25
    assert min(xs) < 3.0 and max(xs) > 7.0  # it crossed to the other room and back
    doorway = [p for p in crowd.people[pid].path if abs(p[0] - 5.0) < 0.3]
    assert all(1.5 < y < 2.5 for _, y in doorway)


def test_unreachable_waypoint_is_rejected() -> None:
    cells = two_rooms().grid.cells.copy()
    cells[:, 99:101] = OCCUPIED  # close the door
    world = World(OccupancyGrid(cells, 0.05, 0.0, 0.0))
    crowd = Crowd(world, np.random.default_rng(0))
    with pytest.raises(PeopleConfigError, match="no walkable path"):
        crowd.add_person([(2.0, 2.0), (8.0, 2.0)])


@pytest.mark.realdata
def test_generated_people_stay_in_free_space_on_willow(shared_data: Path) -> None:
    world = World(load_map(shared_data / "maps" / "willow.yaml"))
    crowd = Crowd(world, np.random.default_rng(7))
    crowd.spawn(6)
    assert run(crowd, world, 60.0) >= 0.0
    moved = [p for p in crowd.people if p.x != p.path[0, 0] or p.y != p.path[0, 1]]
    assert len(moved) == 6


def test_person_yields_to_the_robot() -> None:
    world = two_rooms()
    cfg = CrowdConfig(pause_probability=0.0, yield_patience=60.0)
    crowd = Crowd(world, np.random.default_rng(0), cfg)
    pid = crowd.add_person([(1.0, 3.0), (4.0, 3.0)], speed=1.0)
    robot = Pose2D(2.5, 3.0, 0.0)  # standing in the person's way
    for _ in range(100):
        crowd.step(0.05, robot, FP)
        p = crowd.people[pid]
        assert FP.distance_to_point(robot, p.x, p.y) >= p.radius + 0.3 - 1e-9
    assert crowd.people[pid].state is PersonState.YIELDING
    xs = []
    for _ in range(40):  # the robot has left: the person walks on past where it stood
        crowd.step(0.05, FAR_AWAY, FP)
        xs.append(crowd.people[pid].x)
    assert max(xs) > 3.0


def test_patient_person_goes_around_a_parked_robot() -> None:
    """After yield_patience a person sidesteps away from the robot and walks on past it."""
    world = two_rooms()
    cfg = CrowdConfig(pause_probability=0.0, yield_patience=2.0)
    crowd = Crowd(world, np.random.default_rng(0), cfg)
    pid = crowd.add_person([(1.0, 3.0), (4.0, 3.0)], speed=1.0)
    robot = Pose2D(2.5, 3.0, 0.0)  # parked in the person's way for good
    xs = []
    for _ in range(300):
        crowd.step(0.05, robot, FP)
        p = crowd.people[pid]
        assert FP.distance_to_point(robot, p.x, p.y) >= p.radius + 0.3 - 1e-9
        xs.append(p.x)
    assert max(xs) > 3.5  # got past the robot, which never moved


def test_person_in_a_doorway_steps_back_and_lets_the_robot_pass() -> None:
    """A doorway stand-off (issue 12): the robot waits just before the door, a person comes
    through it towards the robot and cannot get round it. Without giving way both would wait
    for ever; the person steps back out of the doorway and leaves it free for a while."""
    world = two_rooms()
    crowd = Crowd(world, np.random.default_rng(0), CrowdConfig(pause_probability=0.0))
    pid = crowd.add_person([(8.0, 2.0), (2.0, 2.0)], speed=1.0)
    robot = Pose2D(4.3, 2.0, 0.0)  # facing the doorway (x 4.95-5.05, y 1.5-2.5)
    states, door_free = [], []
    for _ in range(400):
        crowd.step(0.05, robot, FP)
        p = crowd.people[pid]
        assert FP.distance_to_point(robot, p.x, p.y) >= p.radius + 0.3 - 1e-9
        states.append(p.state)
        door_free.append(np.hypot(p.x - 5.0, p.y - 2.0) > 0.9)
    assert PersonState.GIVING_WAY in states
    first = states.index(PersonState.GIVING_WAY)
    assert first * 0.05 < 12.0  # after yield_patience (3 s) and a few shuffles
    assert sum(door_free[first:]) * 0.05 >= 5.0  # the doorway stays free for the robot


def test_blocker_stops_in_front_of_the_robot() -> None:
    world = two_rooms()
    cfg = CrowdConfig(pause_probability=0.0, blocker_probability=1.0, blocker_duration=(4.0, 4.0))
    crowd = Crowd(world, np.random.default_rng(0), cfg)
    pid = crowd.add_person([(4.5, 3.0), (4.5, 0.5)], blocker=True, speed=1.0)
    robot = Pose2D(2.5, 2.0, 0.0)  # facing +x; the person walks across 2 m ahead
    states = []
    for _ in range(60):
        crowd.step(0.05, robot, FP)
        states.append(crowd.people[pid].state)
    assert PersonState.BLOCKING in states
    p = crowd.people[pid]
    assert p.state is PersonState.BLOCKING
    local = Pose2D(p.x, p.y, 0.0).relative_to(robot)
    assert 0.3 < local.x < 0.3 + 2.5 and abs(local.y) < 0.8


def test_scripted_block() -> None:
    crowd = Crowd(two_rooms(), np.random.default_rng(0))
    pid = crowd.add_person([(1.0, 1.0), (4.0, 3.0)])
    person = crowd.people[pid]  # ids count from 0 in creation order
    person.state, person.timer = PersonState.BLOCKING, 1.0  # as a blocker starts blocking
    x0 = person.x
    for _ in range(10):
        crowd.step(0.05, FAR_AWAY, FP)
    assert person.x == x0


def test_crowd_is_deterministic_for_a_seed() -> None:
    def trajectory(seed: int) -> np.ndarray:
        world = two_rooms()
        crowd = Crowd(world, np.random.default_rng(seed))
        crowd.spawn(3)
        out = []
        for _ in range(200):
            crowd.step(0.05, FAR_AWAY, FP)
            out.append(crowd.circles())
        return np.array(out)

    assert np.array_equal(trajectory(3), trajectory(3))
    assert not np.array_equal(trajectory(3), trajectory(4))


def test_nobody_starts_inside_the_robot() -> None:
    """Issue 12, Willow seed 7: a person spawned 0.23 m from the robot's centre, inside its body;
    the robot could not move and was reported blocked at its start. A route whose first waypoint
    is at the robot is entered at its next waypoint clear of it, with no extra random draws."""
    world = two_rooms()
    robot = Pose2D(2.5, 3.0, 0.0)
    route = [(2.6, 3.1), (2.5, 2.6), (7.0, 3.0), (7.0, 1.0)]  # the 2nd is 0.15 m off its body
    crowds = [Crowd(world, np.random.default_rng(3)) for _ in range(2)]
    for crowd in crowds:
        crowd.random_route = lambda n_waypoints=4, min_clearance=0.6: list(route)  # type: ignore[method-assign]
    crowds[0].spawn(2)
    crowds[1].spawn(2, robot=(robot, FP))
    first = crowds[0].people[0]  # without the robot given: at the first waypoint (on the lattice)
    assert np.hypot(first.x - 2.6, first.y - 3.1) < 0.2
    person = crowds[1].people[0]
    assert np.hypot(person.x - 7.0, person.y - 3.0) < 0.2
    assert FP.distance_to_point(robot, person.x, person.y) >= 0.25 + 0.3
    # the same random draws: the blocker flags (drawn after each route) agree
    assert [p.blocker for p in crowds[0].people] == [p.blocker for p in crowds[1].people]
    with pytest.raises(PeopleConfigError, match=r"within 0\.55 m of the robot"):
        crowds[1]._start_clear_of([(2.6, 3.1), (2.5, 2.6)], robot, FP)


@pytest.mark.realdata
def test_nobody_starts_inside_the_robot_on_willow_seed_7(shared_data: Path) -> None:
    from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem

    root = Path(__file__).resolve().parents[3]
    system = SimulatedSystem(
        ScenarioOptions(
            map_yaml=shared_data / "maps" / "willow.yaml",
            topo_yaml=root / "maps" / "willow_topo.yaml",
            seed=7,
        )
    )
    assert system.sim.min_clearance() > 0.25
