"""Doors and corridors as narrow as issue 12 asks the robot to pass (0.9 m and 1.1 m for a robot
0.55 m wide), on the whole stack in the realistic world (walls redrawn off the map, UTM-30LX noise,
odometry slip, the pose set by hand, the collision monitor under the multiplexer); and a 0.6 m gap
it cannot pass, which it must report with where and why.

The building, 16 x 6 m: room A | a wall at x = 4 m with a door centred at y = 4 m | a hall |
a corridor from x = 8 to 14 m centred at y = 2.5 m | room B. Furniture makes it unambiguous to
the localiser. The graph's arcs run through the middle of the door and the corridor (the
realistic world keeps its clutter off the arcs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from interbot_core.supervisor import TaskFinished
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, drive_to_pose

RES = 0.05
DOOR_X = (4.0, 4.1)  # [m] the wall with the door
DOOR_Y = 4.0  # [m] door centre
CORRIDOR_X = (8.0, 14.0)  # [m]
CORRIDOR_Y = 2.5  # [m] corridor centre
GOAL = Pose2D(15.0, 3.0, 0.0)  # room B


def building(tmp: Path, door: float, corridor: float) -> ScenarioOptions:
    """The map and graph above with a ``door`` [m] wide door and a ``corridor`` [m] wide corridor."""
    width, height = 16.0, 6.0
    cells = np.full((round(height / RES), round(width / RES)), FREE, dtype=np.int8)

    def rect(x0: float, y0: float, x1: float, y1: float, value: int) -> None:
        cells[round(y0 / RES) : round(y1 / RES), round(x0 / RES) : round(x1 / RES)] = value

    rect(0.0, 0.0, width, 0.1, OCCUPIED)
    rect(0.0, height - 0.1, width, height, OCCUPIED)
    rect(0.0, 0.0, 0.1, height, OCCUPIED)
    rect(width - 0.1, 0.0, width, height, OCCUPIED)
    rect(DOOR_X[0], 0.0, DOOR_X[1], height, OCCUPIED)
    rect(DOOR_X[0], DOOR_Y - door / 2, DOOR_X[1], DOOR_Y + door / 2, FREE)
    rect(CORRIDOR_X[0], 0.0, CORRIDOR_X[1], height, OCCUPIED)
    rect(CORRIDOR_X[0], CORRIDOR_Y - corridor / 2, CORRIDOR_X[1], CORRIDOR_Y + corridor / 2, FREE)
    rect(2.3, 1.0, 2.7, 1.4, OCCUPIED)  # a pillar in room A
    rect(0.1, 4.6, 0.7, 5.4, OCCUPIED)  # a cabinet against its west wall
    rect(6.2, 0.1, 7.0, 0.7, OCCUPIED)  # a desk in the hall
    rect(5.0, 5.3, 5.6, 5.9, OCCUPIED)  # a shelf in the hall
    map_yaml = OccupancyGrid(cells, RES, 0.0, 0.0, source="narrow").save(tmp / "narrow.yaml")
    nodes = [
        ("Room A", 1.5, 3.0, True),
        ("Door west", 3.3, DOOR_Y, False),
        ("Door east", 4.8, DOOR_Y, False),
        ("Corridor west", 7.5, CORRIDOR_Y, False),
        ("Corridor east", 14.5, CORRIDOR_Y, False),
        ("Room B", GOAL.x, GOAL.y, True),
    ]
    topo = {
        "map": map_yaml.name,
        "nodes": [
            {"id": i, "name": name, "x": x, "y": y, "yaw": 0.0, "tour": tour, "home": i == 0}
            for i, (name, x, y, tour) in enumerate(nodes)
        ],
        "arcs": [[i, i + 1] for i in range(len(nodes) - 1)],
    }
    topo_yaml = tmp / "narrow_topo.yaml"
    topo_yaml.write_text(yaml.safe_dump(topo))
    return ScenarioOptions(map_yaml=map_yaml, topo_yaml=topo_yaml, seed=2, people=0)


def test_drives_through_a_door_of_0_9_m_and_a_corridor_of_1_1_m(tmp_path: Path) -> None:
    system = SimulatedSystem(building(tmp_path, door=0.9, corridor=1.1))
    system.localise()
    door_clearance: list[float] = []
    corridor_clearance: list[float] = []
    original_step = system.step

    def step() -> None:  # ground truth for the figures only
        original_step()
        truth = system.sim.true_pose()
        if DOOR_X[0] - 0.3 <= truth.x <= DOOR_X[1] + 0.3:
            door_clearance.append(system.sim.min_clearance())
        elif CORRIDOR_X[0] + 0.3 <= truth.x <= CORRIDOR_X[1] - 0.3:
            corridor_clearance.append(system.sim.min_clearance())

    system.step = step  # type: ignore[method-assign]
    reached = drive_to_pose(system, GOAL, max_time=240.0)
    print(
        f"t={system.now:.1f} s, door clearance min {min(door_clearance):.3f} m, corridor min"
        f" {min(corridor_clearance):.3f} m"
    )
    assert reached, system.of(TaskFinished)
    assert system.sim.collisions == 0
    assert door_clearance and corridor_clearance  # it went through both
    # 0.175 m a side when centred in the door, 0.275 m in the corridor: the planner keeps to
    # the middle and the controllers let it through slowly, not scraping a frame. The
    # realistic world redraws the walls off the map (rooms offset by a few cm, clutter), so
    # the truth's corridor can be narrower than the map's: with the localiser's lateral error
    # at 0 cm, seed 2's worst corridor clearance is 0.14 m on one side, 5.5 cm off the
    # map's centre line.
    assert min(door_clearance) >= 0.08
    assert min(corridor_clearance) >= 0.10


def test_a_gap_of_0_6_m_is_reported_blocked_with_where_and_why(tmp_path: Path) -> None:
    system = SimulatedSystem(building(tmp_path, door=0.6, corridor=1.1))
    system.localise()
    reached = drive_to_pose(system, GOAL, max_time=60.0)
    assert not reached
    reason = system.of(TaskFinished)[-1][1].reason
    assert "unreachable" in reason and "narrows to 0.55-0.60 m at (4.0" in reason, reason
    assert system.sim.true_pose().distance_to(system.start_pose) < 0.05  # it did not set off
    assert system.sim.collisions == 0
