"""Which pose the stack acts on and which it reports (issue 12, `map_offset`).

The localiser estimates the robot's pose on the map (where the map's walls are relative to the
robot) and, beside it, its position in the building (the map's own offset there taken out).
Navigation plans among the map's walls and its stops are the map's: it acts on the map pose
(`RobotStack.map_pose`). What the robot reports (the station, the tablet, the figures) is its
best estimate in the building (`RobotStack.pose`). The two differ by a few centimetres (once
the building-pose filter has learnt its odometry's walk; before, and with the filter off, both
are the map pose).
"""

from __future__ import annotations

import msgspec
import numpy as np

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.map_offset import MapOffsetConfig
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, daemon_localiser_config
from robot_daemon.stack import StackConfig
from tests.robot_daemon.stack_route import localise_and_send_route

GOAL_NODE = 2  # Secretariat, via node 1: down the west corridor from node 0


def test_navigation_acts_on_the_map_pose_and_the_building_pose_is_reported() -> None:
    # estimating from the first scan (by default after ~10 m: `MapOffset.estimating`), so
    # that 15 s of driving show the two apart
    localiser = msgspec.structs.replace(
        daemon_localiser_config(), map_offset=MapOffsetConfig(walk_prior_windows=0.0)
    )
    system = SimulatedSystem(
        ScenarioOptions(seed=5, people=0), stack_config=StackConfig(localiser=localiser)
    )
    stack = system.stack
    localise_and_send_route(system, GOAL_NODE)
    given: list[tuple[Pose2D, Pose2D, Pose2D]] = []  # (to the navigator, map, reported)
    update = stack.navigator.update

    def spy(now: float, at: Pose2D, scan: object) -> object:
        reported, on_map = stack.pose, stack.map_pose
        assert reported is not None and on_map is not None
        given.append((at, on_map, reported))
        return update(now, at, scan)  # type: ignore[arg-type]

    stack.navigator.update = spy  # type: ignore[method-assign]
    system.run_until(lambda: False, 15.0)
    assert len(given) > 50
    assert all(at == on_map for at, on_map, _ in given)
    apart = np.array([on_map.distance_to(reported) for _, on_map, reported in given])
    assert apart.max() > 1e-4  # the building pose is an estimate of its own ...
    assert apart.max() < stack.localiser.config.map_offset.max_offset_m  # ... near the map's
    # the covariance published is the building pose's
    cov = stack.pose_covariance
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0.0)
