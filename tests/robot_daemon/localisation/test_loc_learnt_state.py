"""The learnt scalar's bookkeeping (`learnt_state.LearntScalar`, shared by the odometry's scale
and heading drift): conditioning on a pose update, its bounds, and what happens without one."""

from __future__ import annotations

import numpy as np
import pytest

from robot_daemon.localisation.learnt_state import LearntScalar, solve_spd3


def _predicted(state: LearntScalar) -> LearntScalar:
    # A scalar fully correlated with x: cov(x, k) = var(k) = var(x) = 0.01.
    state.remember_prediction((0.01, 0.0, 0.0), 0.01)
    return state


def test_a_pose_correction_teaches_the_scalar_by_gaussian_conditioning() -> None:
    state = _predicted(LearntScalar(0.0, 0.01, -1.0, 1.0, 1e-12))
    cov_pred = np.diag([0.01, 0.01, 0.01])
    cov_post = np.diag([0.0025, 0.01, 0.01])  # x measured with variance 1/300
    state.update(cov_pred, cov_post, np.array([0.2, 0.0, 0.0]))
    # A = c P⁻¹ = (1, 0, 0): the scalar moves with x, and keeps x's posterior variance.
    assert state.value == pytest.approx(0.2)
    assert state.var == pytest.approx(0.0025)
    assert state.cross == pytest.approx((0.0025, 0.0, 0.0))


def test_the_value_stays_within_its_bounds_and_the_variance_above_its_floor() -> None:
    state = _predicted(LearntScalar(0.0, 0.01, -0.1, 0.1, 1e-6))
    state.update(np.diag([0.01] * 3), np.zeros((3, 3)), np.array([5.0, 0.0, 0.0]))
    assert state.value == 0.1
    assert state.var == 1e-6  # 0.01 - 0.01 learnt away: the floor


def test_without_an_update_the_prediction_stands_and_a_new_pose_drops_the_cross() -> None:
    state = _predicted(LearntScalar(0.5, 0.04, -1.0, 1.0, 1e-12))
    state.keep_prediction()
    assert (state.value, state.var, state.cross) == (0.5, 0.01, (0.01, 0.0, 0.0))
    state.update(np.eye(3), np.eye(3), np.ones(3))  # no prediction pending: nothing changes
    assert (state.value, state.var) == (0.5, 0.01)
    state.reset_cross()
    assert state.cross == (0.0, 0.0, 0.0)
    assert (state.value, state.var) == (0.5, 0.01)  # a property of the robot: kept


def test_a_singular_prior_keeps_the_prediction() -> None:
    state = _predicted(LearntScalar(0.0, 0.04, -1.0, 1.0, 1e-12))
    state.update(np.zeros((3, 3)), np.zeros((3, 3)), np.ones(3))
    assert (state.value, state.var, state.cross) == (0.0, 0.01, (0.01, 0.0, 0.0))
    assert solve_spd3([[0.0] * 3] * 3, (1.0, 0.0, 0.0)) is None
    m = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]])
    b = (1.0, -2.0, 0.5)
    assert solve_spd3(m.tolist(), b) == pytest.approx(tuple(np.linalg.solve(m, b)))
