"""The kidnap check does not take people for a kidnap of a well-localised robot (issue 12).

Two realistic Willow Garage tours lost a robot that knew where it was: standing in a tight
place among people, most of its scan lay within ``kidnap_min_range_m`` (1.5 m) of the laser
and the check judged on what was left (136 and 234 end points of ~1075), of which people just
beyond 1.5 m covered a quarter to a half. A far place whose walls lie where those people stood
fitted them 0.90-0.96 against 0.58-0.78 at the tracked pose, and ONE scan's comparison declared
a kidnap (seed 6: 5 of 14 stops, then "help me!" and lost; seed 5: a loss and an 8 s search).

Each situation is rebuilt here from the scenario's own building (the realistic world of the
tour's seed), with the robot and the people where they stood (from the tour's trace) and the
simulator's laser; the tracked pose is the truth. The wall model is the one the tour learnt on
Willow (cell faces). Both rules that now stop the alarm are the ones the relocaliser already
applies elsewhere: a far place must fit the *whole* scan ``kidnap_margin`` better too (the
near end points hold the walls that define a tight place), and must not need clearly more of
the beams to pass through its walls than the tracked pose (people only shorten beams).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig
from robot_daemon.localisation.relocaliser import Relocaliser
from robot_daemon.localisation.wall_model import wall_model_setting
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem

REPO = Path(__file__).resolve().parents[3]
# seed -> (the robot's true pose, the people (x, y, radius)) when the check fired on `main`
# 0443669 (`interbot scenario tour --seed N --map willow.yaml --topo maps/willow_topo.yaml`)
SCENES: dict[int, tuple[Pose2D, list[tuple[float, float, float]]]] = {
    # t = 516.2 s, standing while the navigator ran recoveries; two people beside the robot
    # (0.85, 0.93 m) and one at 1.8 m whose end points were a fifth of those beyond 1.5 m;
    # the alarm named (35.68, 14.03), quality 0.96 against 0.78.
    6: (
        Pose2D(20.970, 21.521, -1.959),
        [(20.65, 20.73, 0.25), (22.34, 20.33, 0.25), (20.29, 20.89, 0.25), (46.58, 17.7, 0.25)],
    ),
    # t = 880.3 s, at a tour stop; people at 0.94, 1.84 and 2.69 m; the alarm named
    # (21.18, 4.19), quality 0.90 against 0.58, a place 46 of whose 65 beams pass through walls.
    5: (
        Pose2D(39.193, 33.807, 0.020),
        [(41.84, 33.3, 0.25), (47.49, 32.44, 0.25), (39.84, 33.13, 0.25), (40.86, 33.04, 0.25)],
    ),
}
SCANS = 4  # scans of each scene (the laser's noise differs), one check each


class Scene:
    """The tour's building at one seed, and a relocaliser with the tour's wall model."""

    def __init__(self, shared_data: Path, seed: int) -> None:
        options = ScenarioOptions(
            seed=seed,
            people=0,
            map_yaml=shared_data / "maps" / "willow.yaml",
            topo_yaml=REPO / "maps" / "willow_topo.yaml",
        )
        self.robot, people = SCENES[seed]
        self.system = SimulatedSystem(options, start_pose=self.robot)
        self.people = np.array(people, dtype=np.float64)
        self.mount = self.system.stack.config.laser_mount
        matcher, wall_model = wall_model_setting("cell_face")
        localiser = Localiser(
            self.system.grid, LocaliserConfig(matcher=matcher, wall_model=wall_model)
        )
        self.relocaliser = Relocaliser(self.system.grid, localiser)
        self.now = 1000.0  # [s] the checks' clock (one check every background_every_s)

    def alarms(
        self, tracked: Pose2D, at: Pose2D | None = None, people: np.ndarray | None = None
    ) -> list[Pose2D]:
        """The places the standing check names on ``SCANS`` scans, tracking ``tracked`` (laser),
        the robot standing at ``at`` among ``people`` (default: the scene's)."""
        found = []
        every = self.relocaliser.config.background_every_s
        for _ in range(SCANS):
            self.now = now = self.now + every
            circles = self.people if people is None else people
            scan = self.system.sim.laser.scan(at or self.robot, now, circles)
            there = self.relocaliser.check_standing(scan, tracked, 0.0, now)
            if there is not None:
                found.append(there.pose)
        return found


@pytest.fixture(scope="module", params=sorted(SCENES))
def scene(request: pytest.FixtureRequest, shared_data: Path) -> Scene:
    return Scene(shared_data, request.param)


@pytest.mark.realdata
def test_people_near_a_well_localised_robot_are_not_a_kidnap(scene: Scene) -> None:
    """Tracked at the truth, among the people of the tour: no alarm on any scan (on `main`,
    seed 6 named (35.68, 14.03) or (6.76, 6.21) on every scan, seed 5 (21.18, 4.19) and
    others: the end points beyond 1.5 m alone decided)."""
    truth = scene.robot.compose(scene.mount)
    assert scene.alarms(truth) == []


@pytest.mark.realdata
def test_a_real_kidnap_between_the_same_places_is_still_caught(scene: Scene) -> None:
    """The rules stop the people's alarm, not a kidnap: the robot carried into the other
    scene's place (the tracked pose left behind; nobody about) is caught at the truth on every
    scan. (Among that scene's people the check cannot confirm the truth either way: refined on
    the end points beyond 1.5 m, half of them on people, it slides 0.9 m off; on `main` such a
    kidnap set the search off only through a look-alike the people made.)"""
    carried_to = next(robot for robot, _ in SCENES.values() if robot != scene.robot)
    tracked = scene.robot.compose(scene.mount)
    named = scene.alarms(tracked, carried_to, np.empty((0, 3)))
    truth = carried_to.compose(scene.mount)
    assert len(named) == SCANS
    assert all(p.distance_to(truth) < 0.3 for p in named), named
