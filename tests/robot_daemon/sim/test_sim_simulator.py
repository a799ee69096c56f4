"""The simulator: collisions, determinism, sensor cadence, metrics and a run on willow."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid, load_map
from robot_daemon.sim.battery import BatteryConfig
from robot_daemon.sim.odometry_model import OdometryErrorModel
from robot_daemon.sim.people import PersonState
from robot_daemon.sim.simulator import SimConfig, SimConfigError, Simulator
from robot_daemon.sim.world import RectObstacle


def room() -> OccupancyGrid:
    """A 10 x 6 m room with one-cell walls (0.05 m cells): free x in [0.05, 9.95]."""
    cells = np.full((120, 200), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyGrid(cells, 0.05, 0.0, 0.0)


def make(**kw: object) -> Simulator:
    cfg = SimConfig(start_pose=Pose2D(5.0, 3.0, 0.0), **kw)  # type: ignore[arg-type]
    return Simulator(room(), cfg, rng_seed=11)


def test_driving_into_a_wall_stops_at_it_once() -> None:
    sim = make()
    sim.set_cmd_vel(0.8, 0.0)
    front = []
    for _ in range(150):  # 15 s: more than enough to reach the wall 4.65 m ahead
        sim.step(0.1)
        sim.set_cmd_vel(0.8, 0.0)  # keep pushing
        front.append(sim.true_pose().x + 0.3)
    assert sim.collisions == 1
    assert max(front) <= 9.95 + 1e-9  # never passes the wall surface
    assert front[-1] == pytest.approx(9.95, abs=0.01)  # stopped at it
    assert sim.min_clearance() == pytest.approx(0.0, abs=0.01)
    assert sim.true_velocity() == pytest.approx((0.0, 0.0), abs=1e-3)
    # Back off past the hysteresis and hit it again: a second collision.
    sim.set_cmd_vel(-0.3, 0.0)
    sim.step(1.0)
    assert sim.collisions == 1
    sim.set_cmd_vel(0.5, 0.0)
    for _ in range(30):
        sim.step(0.1)
        sim.set_cmd_vel(0.5, 0.0)
    assert sim.collisions == 2


def test_collision_with_person_and_obstacle() -> None:
    sim = make(odometry=OdometryErrorModel.perfect())
    sim.add_person([(8.0, 3.0), (8.0, 3.2)])
    person = sim.crowd.people[0]
    person.state, person.timer = PersonState.BLOCKING, 100.0  # stands where it is
    sim.set_cmd_vel(0.5, 0.0)
    for _ in range(100):
        sim.step(0.1)
        sim.set_cmd_vel(0.5, 0.0)
    assert sim.collisions == 1
    gap = sim.config.footprint.distance_to_point(sim.true_pose(), person.x, person.y)
    assert gap == pytest.approx(person.radius, abs=0.01)
    sim.teleport(Pose2D(2.0, 1.0, 0.0))
    sim.add_obstacle(RectObstacle(4.25, 1.0, 0.5, 2.0))
    for _ in range(60):
        sim.step(0.1)
        sim.set_cmd_vel(0.5, 0.0)
    assert sim.collisions == 2
    assert sim.true_pose().x + 0.3 <= 4.0 + 0.05


def trajectory(seed: int, n_people: int = 2) -> tuple[list[Pose2D], list[np.ndarray]]:
    cfg = SimConfig(
        start_pose=Pose2D(5.0, 3.0, 0.0),
        odometry=OdometryErrorModel.uncalibrated(noise_per_sqrt_m=0.01),
        n_people=n_people,
    )
    sim = Simulator(room(), cfg, rng_seed=seed)
    poses, scans = [], []
    for k in range(200):
        sim.set_cmd_vel(0.4, 0.8 * math.sin(k / 30))
        sim.step(0.01)
        poses.append(sim.odometry().pose)
        if sim.scan_due() and k % 4 == 0:
            scans.append(sim.scan().ranges.copy())
    return poses, scans


def test_same_seed_same_run_different_seed_differs() -> None:
    a, b, c = trajectory(5), trajectory(5), trajectory(6)
    assert a[0] == b[0]
    assert all(np.array_equal(x, y) for x, y in zip(a[1], b[1], strict=True))
    assert a[0] != c[0]


def test_scan_cadence_is_40_hz_in_sim_time() -> None:
    sim = make()
    stamps = []
    for _ in range(100):  # sim time 0.00 .. 0.99 s
        if sim.scan_due():
            stamps.append(sim.scan().stamp)
        sim.step(0.01)
    assert len(stamps) == 40
    assert stamps[:4] == pytest.approx([0.0, 0.03, 0.05, 0.08])  # on the 10 ms step grid
    assert np.diff(stamps).mean() == pytest.approx(0.025, abs=0.001)
    sim.scan()
    assert not sim.scan_due()  # a scan just taken resets the period
    frames = 0
    for _ in range(100):
        if sim.camera_due():
            assert sim.camera_frame().shape == (240, 320, 3)
            frames += 1
        sim.step(0.01)
    assert frames == 10


def test_step_remainder_carries_over() -> None:
    sim = make()
    for _ in range(10):
        sim.step(0.003)
    assert sim.time == pytest.approx(0.03)
    with pytest.raises(SimConfigError, match="dt"):
        sim.step(-1.0)


def test_truth_and_odometry_differ_after_kidnapping() -> None:
    sim = make(odometry=OdometryErrorModel.perfect())
    sim.set_cmd_vel(0.5, 0.0)
    sim.step(2.0)
    odom_before = sim.odometry().pose
    sim.teleport(Pose2D(2.0, 2.0, 1.0))
    sim.step(0.5)
    assert sim.true_pose() == Pose2D(2.0, 2.0, 1.0)  # velocities were zeroed
    assert sim.odometry().pose == odom_before


def test_cmd_timeout_stops_the_robot() -> None:
    sim = make(cmd_timeout=0.5)
    sim.set_cmd_vel(0.5, 0.0)
    sim.step(3.0)
    assert sim.true_velocity() == (0.0, 0.0)
    assert sim.true_pose().x < 5.0 + 0.5 * 0.5 + 0.5


def test_battery_cutoff_stops_motors() -> None:
    sim = make(battery=BatteryConfig(capacity_ah=0.001, initial_soc=0.05))
    sim.set_cmd_vel(0.3, 0.0)
    sim.step(3.0)
    assert sim.battery().cutoff
    x = sim.true_pose().x
    sim.set_cmd_vel(0.3, 0.0)
    sim.step(1.0)
    assert sim.true_pose().x == x


def test_odometry_reading_velocities() -> None:
    sim = make(odometry=OdometryErrorModel.perfect())
    sim.set_cmd_vel(0.4, 0.2)
    sim.step(3.0)
    reading = sim.odometry()
    assert reading.stamp == pytest.approx(3.0)
    assert (reading.linear, reading.angular) == pytest.approx((0.4, 0.2))


@pytest.mark.realdata
def test_runs_on_willow_with_people(shared_data: Path) -> None:
    sim = Simulator(
        load_map(shared_data / "maps" / "willow.yaml"), SimConfig(n_people=3), rng_seed=2
    )
    start = sim.true_pose()
    assert sim.world.clearance_at(start.x, start.y) > 1.0
    for k in range(300):  # 3 s at 100 Hz, scans at 10 Hz
        sim.set_cmd_vel(0.5, 0.3)
        sim.step(0.01)
        if k % 10 == 0:
            scan = sim.scan()
            assert scan.valid().sum() > 500
    assert sim.collisions == 0
    assert sim.true_pose().distance_to(start) > 0.5
    assert sim.min_clearance() > 0.0


def test_invalid_config() -> None:
    with pytest.raises(SimConfigError, match="internal_dt"):
        SimConfig(internal_dt=0.0)
