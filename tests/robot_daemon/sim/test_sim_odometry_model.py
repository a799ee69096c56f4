"""Odometry error model: thesis §6.1 speed errors (~8 % uncalibrated, ~3 % calibrated)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon.sim.odometry_model import (
    OdometryConfigError,
    OdometryErrorModel,
    WheelOdometry,
    true_body_velocity,
)
from robot_daemon.sim.simulator import SimConfig, Simulator


def hall() -> OccupancyGrid:
    """A 40 x 10 m empty hall, 0.1 m cells, walls on the border."""
    cells = np.full((100, 400), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyGrid(cells, 0.1, 0.0, 0.0)


def drive(model: OdometryErrorModel, linear: float, angular: float, seconds: float) -> Simulator:
    cfg = SimConfig(odometry=model, start_pose=Pose2D(2.0, 5.0, 0.0))
    sim = Simulator(hall(), cfg, rng_seed=1)
    sim.set_cmd_vel(linear, angular)
    sim.step(seconds)
    return sim


def test_perfect_model_equals_truth() -> None:
    sim = drive(OdometryErrorModel.perfect(), 0.5, 0.1, 20.0)
    truth = sim.true_pose().relative_to(Pose2D(2.0, 5.0, 0.0))
    odom = sim.odometry().pose
    assert (odom.x, odom.y, odom.yaw) == pytest.approx((truth.x, truth.y, truth.yaw), abs=1e-9)


@pytest.mark.parametrize(
    ("model", "low", "high"),
    [
        (OdometryErrorModel.uncalibrated(), 0.07, 0.09),
        (OdometryErrorModel.calibrated(), 0.02, 0.04),
    ],
)
def test_corridor_speed_error_matches_thesis(
    model: OdometryErrorModel, low: float, high: float
) -> None:
    # Thesis Table 6.1/6.2: 26 m corridor at 0.6 m/s (expected 43.3 s).
    sim = drive(model, 0.6, 0.0, 26.0 / 0.6)
    true_distance = sim.true_pose().distance_to(Pose2D(2.0, 5.0, 0.0))
    odom_distance = math.hypot(sim.odometry().pose.x, sim.odometry().pose.y)
    assert sim.collisions == 0
    speed_error = abs(true_distance - odom_distance) / odom_distance
    assert low <= speed_error <= high
    # The odometry believes the command (minus the acceleration ramp) was executed.
    assert odom_distance == pytest.approx(26.0 - 0.6 * 0.6 / 0.6 / 2, abs=0.1)


@pytest.mark.parametrize(
    ("model", "low", "high"),
    [
        (OdometryErrorModel.uncalibrated(), 0.07, 0.09),
        (OdometryErrorModel.calibrated(), 0.02, 0.04),
    ],
)
def test_rotation_speed_error_matches_thesis(
    model: OdometryErrorModel, low: float, high: float
) -> None:
    v, w = true_body_velocity(model, 0.46, 0.0, 0.6)
    assert v == pytest.approx(0.0, abs=0.01)
    assert low <= abs(w - 0.6) / 0.6 <= high


def test_odometry_drifts_while_truth_does_not_jump() -> None:
    sim = drive(OdometryErrorModel.uncalibrated(), 0.4, 0.2, 15.0)
    truth = sim.true_pose().relative_to(Pose2D(2.0, 5.0, 0.0))
    odom = sim.odometry().pose
    assert math.hypot(truth.x - odom.x, truth.y - odom.y) > 0.2


def test_noise_is_deterministic_per_seed() -> None:
    model = OdometryErrorModel(noise_per_sqrt_m=0.01)

    def run(seed: int) -> Pose2D:
        odo = WheelOdometry(model, 0.46, np.random.default_rng(seed))
        for _ in range(500):
            odo.update(0.01, 0.011, 0.01)
        return odo.pose

    assert run(4) == run(4)
    assert run(4) != run(5)


def test_velocity_reading() -> None:
    odo = WheelOdometry(OdometryErrorModel.perfect(), 0.5, np.random.default_rng(0))
    odo.update(0.009, 0.011, 0.02)
    assert odo.velocity == pytest.approx((0.5, 0.2))


def test_invalid_model_is_rejected() -> None:
    with pytest.raises(OdometryConfigError, match="track_scale"):
        OdometryErrorModel(track_scale=0.1)
    with pytest.raises(OdometryConfigError, match="noise_per_sqrt_m"):
        OdometryErrorModel(noise_per_sqrt_m=-1.0)
