"""The odometry's scale, learnt online from matched motion (`odometry_scale`, issue 12).

Odometry that reports 5 % too much travel, fused with scans that fix the pose, must teach the
filter a scale near 1 / 1.05; a corridor that does not fix the position along it must then be
crossed with the learnt scale (the drift of the noise alone, not 5 % of the distance) and with
an uncertainty along it that grows linearly with an unknown scale, not as its square root.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserConfig
from robot_daemon.localisation.odometry_scale import (
    OdometryScale,
    OdometryScaleConfig,
    OdometryScaleConfigError,
)

ODOM_SCALE = 1.05  # odometry / true translation


def _kalman_drive(scale: OdometryScale, steps: int, measured: bool) -> tuple[float, float]:
    """Drive east 0.1 m a step with 5 %-long odometry; each step the pose is measured with
    1 cm sigma along x (``measured``) or not at all. Returns (position error [m], sigma x)."""
    rng = np.random.default_rng(1)
    truth, est = 0.0, 0.0
    cov = np.diag([0.01**2, 0.01**2, 0.001**2])
    info = np.diag([1.0 / 0.01**2, 1.0 / 0.01**2, 1.0 / 0.001**2])
    for _ in range(steps):
        truth += 0.1
        raw = Pose2D(0.1 * ODOM_SCALE, 0.0, 0.0)
        step = scale.scaled(raw)
        base = cov + np.diag([0.002**2, 0.002**2, 1e-6])
        cov_pred = scale.predict(Pose2D(est, 0.0, 0.0), raw, step, base)
        pred = est + step.x
        if measured:
            z = truth + rng.normal(0.0, 0.01)
            post = np.linalg.inv(np.linalg.inv(cov_pred) + info)
            corr = post @ info @ np.array([z - pred, 0.0, 0.0])
            est, cov = pred + corr[0], post
            scale.update(cov_pred, post, corr)
        else:
            est, cov = pred, cov_pred
            scale.keep_prediction()
    return abs(est - truth), math.sqrt(cov[0, 0])


def test_scale_is_learnt_where_the_pose_is_measured_then_carries_the_pose() -> None:
    scale = OdometryScale()
    _kalman_drive(scale, 100, measured=True)  # 10 m with the pose pinned
    assert scale.value == pytest.approx(1.0 / ODOM_SCALE, abs=0.005)
    sigma_k = math.sqrt(scale.var)
    assert sigma_k < 0.01
    error, sigma = _kalman_drive(scale, 100, measured=False)  # 10 m blind
    assert error < 0.05  # without the scale: 0.5 m
    assert error < 3.0 * sigma  # and the covariance covers it


def test_an_unknown_scale_makes_the_blind_uncertainty_grow_linearly() -> None:
    """With nothing learnt (prior 5 %), 10 m blind leave sigma >= 0.05 x 10 m along the travel:
    the 0.5 m a 5 % scale error makes, not the few centimetres of independent noise."""
    error, sigma = _kalman_drive(OdometryScale(), 100, measured=False)
    assert error == pytest.approx(0.5, abs=0.02)
    assert sigma >= 0.05 * 10.0 * 0.95
    off = OdometryScale(OdometryScaleConfig(enabled=False))
    error_off, sigma_off = _kalman_drive(off, 100, measured=False)
    assert error_off == pytest.approx(0.5, abs=0.02) and sigma_off < 0.05  # overconfident


def test_localiser_learns_the_scale_in_the_office(world) -> None:
    """The synthetic office (walls in every direction): 5 %-long odometry is learnt."""
    loc = Localiser(world.grid, LocaliserConfig(map_update=False))
    poses = [Pose2D(4.0 + 0.05 * k, 4.0, 0.0) for k in range(160)]  # 8 m east at 0.5 m/s
    odom = Pose2D(0.0, 0.0, 0.0)
    loc.on_odometry(odom, 0.0)
    loc.set_initial_pose(poses[0], 0.0)
    for k in range(1, len(poses)):
        inc = poses[k].relative_to(poses[k - 1])
        odom = odom.compose(Pose2D(inc.x * ODOM_SCALE, inc.y, inc.yaw))
        loc.on_odometry(odom, k / 10.0)
        est = loc.on_scan(world.scan(poses[k], k / 10.0), k / 10.0)
        assert est.pose is not None and est.pose.distance_to(poses[k]) < 0.05
    assert loc.scale.value == pytest.approx(1.0 / ODOM_SCALE, abs=0.01)


@pytest.mark.parametrize(
    ("field", "value"),
    [("sigma", 0.0), ("sigma", math.nan), ("walk_per_sqrt_m", -1.0), ("max_error", 2.0)],
)
def test_bad_scale_config_is_refused_naming_the_field(field: str, value: float) -> None:
    with pytest.raises(OdometryScaleConfigError, match=field):
        OdometryScaleConfig(**{field: value})
