"""Odometry calibration (thesis §6.1): the estimator on synthetic data, then end to end.

Synthetic segments follow the differential-drive model directly (true arc = k · measured arc,
true track = k_b · believed track) with noise on the reference; the end-to-end test runs
`interbot calibrate odometry` on the simulator with 5 % wheel-radius and 4 % track errors, where
the reference is the scan matcher, and checks that the re-run after the correction is within 1.5 %.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_cli.main import main as interbot_main
from robot_daemon.calibration import (
    CalibrationError,
    KinematicParameters,
    SegmentKind,
    SegmentMeasurement,
    estimate_correction,
    format_table,
)
from robot_daemon.sim.diff_drive import wheel_speeds

TRACK = 0.46  # [m] believed


def synthetic_routine(
    k_left: float,
    k_right: float,
    k_track: float,
    rng: np.random.Generator,
    *,
    distance: float = 5.0,
    sigma_m: float = 0.01,
    sigma_rad: float = 0.005,
) -> list[SegmentMeasurement]:
    """Forward, 2π CCW, back, 2π CW as the odometry reports them, and the true motion + noise."""
    segments = []
    for kind, d_odom, th_odom in (
        (SegmentKind.STRAIGHT, distance, 0.0),
        (SegmentKind.ROTATION, 0.0, math.tau),
        (SegmentKind.STRAIGHT, -distance, 0.0),
        (SegmentKind.ROTATION, 0.0, -math.tau),
    ):
        left, right = wheel_speeds(d_odom, th_odom, TRACK)  # the wheel arcs
        d_true = 0.5 * (k_left * left + k_right * right)
        th_true = (k_right * right - k_left * left) / (k_track * TRACK)
        command = 0.4 if kind is SegmentKind.STRAIGHT else 0.6
        motion = d_odom if kind is SegmentKind.STRAIGHT else th_odom
        segments.append(
            SegmentMeasurement(
                kind,
                math.copysign(command, motion),
                abs(motion) / command,
                d_odom,
                th_odom,
                d_true + float(rng.normal(0.0, sigma_m)),
                th_true + float(rng.normal(0.0, sigma_rad)),
                d_true,
                th_true,
            )
        )
    return segments


def test_exact_data_gives_the_exact_correction() -> None:
    segments = synthetic_routine(0.95, 0.97, 1.04, np.random.default_rng(0), sigma_m=0, sigma_rad=0)
    c = estimate_correction(segments, TRACK)
    assert c.left_scale == pytest.approx(0.95, abs=1e-9)
    assert c.right_scale == pytest.approx(0.97, abs=1e-9)
    assert c.track_scale == pytest.approx(1.04, abs=1e-9)
    assert c.residual_rms < 1e-9 and c.segments == 4


@settings(max_examples=100, deadline=None)
@given(
    k_left=st.floats(0.85, 1.15),
    k_right=st.floats(0.85, 1.15),
    k_track=st.floats(0.85, 1.15),
    seed=st.integers(0, 2**31),
)
def test_known_scale_errors_are_recovered_within_one_percent(
    k_left: float, k_right: float, k_track: float, seed: int
) -> None:
    segments = synthetic_routine(k_left, k_right, k_track, np.random.default_rng(seed))
    c = estimate_correction(segments, TRACK)
    assert c.left_scale == pytest.approx(k_left, rel=0.01)
    assert c.right_scale == pytest.approx(k_right, rel=0.01)
    assert c.track_scale == pytest.approx(k_track, rel=0.01)
    assert c.wheel_radius_scale == pytest.approx(0.5 * (k_left + k_right), rel=0.01)


def test_applying_the_correction_makes_odometry_match_the_reference() -> None:
    believed = KinematicParameters(0.1, 0.1, TRACK)
    segments = synthetic_routine(1.03, 1.01, 0.95, np.random.default_rng(1), sigma_m=0, sigma_rad=0)
    proposed = estimate_correction(segments, TRACK).apply(believed)
    assert proposed.wheel_radius_left == pytest.approx(0.103)
    assert proposed.wheel_radius_right == pytest.approx(0.101)
    assert proposed.wheel_radius == pytest.approx(0.102)
    assert proposed.track == pytest.approx(0.95 * TRACK)


def test_the_heading_drift_of_a_straight_run_separates_the_wheels() -> None:
    segments = synthetic_routine(0.98, 1.02, 1.0, np.random.default_rng(2), sigma_m=0, sigma_rad=0)
    straight = segments[0]
    assert straight.ref_rotation > 0  # right wheel really larger: the robot veers left
    c = estimate_correction(segments, TRACK)
    assert c.right_scale > c.left_scale


def test_missing_sections_are_refused_with_the_reason() -> None:
    segments = synthetic_routine(1.0, 1.0, 1.0, np.random.default_rng(3))
    straights = [s for s in segments if s.kind is SegmentKind.STRAIGHT]
    rotations = [s for s in segments if s.kind is SegmentKind.ROTATION]
    with pytest.raises(CalibrationError, match="track is undetermined"):
        estimate_correction(straights, TRACK)
    with pytest.raises(CalibrationError, match="wheel radius is undetermined"):
        estimate_correction(rotations, TRACK)
    with pytest.raises(CalibrationError, match="track must be > 0"):
        estimate_correction(segments, 0.0)


def test_a_lost_reference_gives_no_implausible_proposal() -> None:
    segments = synthetic_routine(1.0, 1.0, 1.0, np.random.default_rng(4))
    broken = [
        SegmentMeasurement(s.kind, s.command, s.duration, s.odom_distance, s.odom_rotation,
                           s.ref_distance * 3, s.ref_rotation * 3)
        for s in segments
    ]  # fmt: skip
    with pytest.raises(CalibrationError, match="implausible"):
        estimate_correction(broken, TRACK)


def test_table_averages_sections_like_table_6_1() -> None:
    segments = synthetic_routine(0.92, 0.92, 1.0, np.random.default_rng(5), sigma_m=0, sigma_rad=0)
    text = format_table("Table", segments)
    straight, rotations = text.splitlines()[2:4]
    # Odometry reports 5 m where the robot went 4.6 m: |5 - 4.6| / 4.6 = 8.7 %.
    assert straight.startswith("straight") and rotations.startswith("rotations")
    assert "5.000 m" in straight and "4.600 m" in straight and "8.696%" in straight
    assert "0.40 m/s" in straight and "0.60 rad/s" in rotations


def test_calibrate_odometry_end_to_end_on_the_simulator(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["calibrate", "odometry", "--sim-wheel-radius-error", "5", "--sim-track-error", "4"]
    assert interbot_main([*argv, "--seed", "2", "--json"]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out.strip().splitlines()[-1])
    assert "Before calibration" in out and "After calibration" in out
    assert figures["max_error_before"] > 0.04  # the mis-set radius shows
    # The estimate (from the scan matcher) against the simulator's truth, a check of the method.
    assert figures["wheel_radius_scale"] == pytest.approx(1 / 1.05, rel=0.01)
    assert figures["track_scale"] == pytest.approx(1 / 1.04, rel=0.01)
    assert figures["max_error_after"] < 0.015
    assert figures["max_truth_error_after"] < 0.015


def test_calibrate_rejects_an_impossible_simulated_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert interbot_main(["calibrate", "odometry", "--sim-track-error", "150"]) == 2
    err = capsys.readouterr().err  # the field, the value and the allowed range
    assert "track_scale = 2.5 is outside the allowed range [0.5, 2]" in err
