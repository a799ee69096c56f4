"""Odometry calibration of a differential drive against a scan-matching reference.

Method. Thesis §6.1 (Test Scenario 1, Tables 6.1/6.2): the robot drives straight runs of a few
metres forward and back and pure rotations of 2π each way; the motion its encoders report
(odometry) is compared with the motion measured independently, here by the scan matcher
against the a-priori map (never ground truth), and the kinematic parameters are corrected.
The correction is the systematic-error model of Borenstein & Feng's UMBmark (IEEE T-RA 12(6),
1996): the distance ratio corrects the wheel radii, the rotation ratio corrects the track.

Model. For one segment the odometry, computed with the believed track ``B``, reports a signed
distance ``d_o`` and rotation ``θ_o``; the wheel arcs it measured are therefore

    L = d_o - θ_o B / 2,    R = d_o + θ_o B / 2.

With radius scales ``k_l, k_r`` (true radius / believed radius, so a true arc is ``k · measured
arc``) and a track scale ``k_b`` (true track / believed track), the reference motion is

    d_ref = (k_l L + k_r R) / 2,                 (straight runs)
    θ_ref = (k_r R - k_l L) / (k_b B),           (every segment)

both linear in ``(k_l, k_r, k_b)`` once the second is written ``k_r R - k_l L - k_b B θ_ref = 0``.
Each row is divided by the size of the motion it describes (so all residuals are relative) and
the stacked system is solved by least squares. Straight runs give ``k_l + k_r`` (distance) and
``k_r - k_l`` (the heading drift of a nominally straight run); rotations then give ``k_b``.
The corrected parameters are ``r_l' = k_l r``, ``r_r' = k_r r``, ``B' = k_b B``.

Pure logic: no I/O, no clock; the routine that drives the robot lives in ``interbot_cli.calibrate``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Annotated, ClassVar

import numpy as np
from msgspec import Meta

from interbot_core import schema
from robot_daemon.sim.diff_drive import wheel_speeds

logger = logging.getLogger(__name__)

MIN_STRAIGHT_M = 0.5  # [m] a straight run shorter than this says little about the radius
MIN_ROTATION_RAD = math.pi / 2  # [rad] likewise for the track


class CalibrationError(ValueError):
    """The measurements cannot determine a correction; the message says what is missing."""


class SegmentKind(StrEnum):
    STRAIGHT = "straight"
    ROTATION = "rotation"


class SegmentMeasurement(schema.Declared, frozen=True):
    """One section of Test Scenario 1, measured from standstill to standstill.

    Distances are signed along the heading at the start of the segment [m]; rotations are
    signed and unwrapped (2π is one full turn counter-clockwise) [rad].
    """

    ROOT: ClassVar[str] = "SegmentMeasurement"
    ERROR: ClassVar[type[Exception]] = CalibrationError
    kind: SegmentKind
    command: schema.Finite  # [m/s] or [rad/s], signed, as commanded
    duration: Annotated[float, Meta(ge=0.0, le=schema.FINITE)]  # [s] the command was applied
    odom_distance: schema.Finite  # [m]
    odom_rotation: schema.Finite  # [rad]
    ref_distance: schema.Finite  # [m] scan matcher against the map
    ref_rotation: schema.Finite  # [rad]
    truth_distance: float | None = None  # [m] simulator only: a check of the method
    truth_rotation: float | None = None  # [rad]

    @property
    def odom_motion(self) -> float:
        """The motion this segment is about: distance [m] or rotation [rad], by odometry."""
        return self.odom_distance if self.kind is SegmentKind.STRAIGHT else self.odom_rotation

    @property
    def ref_motion(self) -> float:
        return self.ref_distance if self.kind is SegmentKind.STRAIGHT else self.ref_rotation

    @property
    def truth_motion(self) -> float | None:
        return self.truth_distance if self.kind is SegmentKind.STRAIGHT else self.truth_rotation

    @property
    def error_rate(self) -> float:
        """|odometry - reference| / |reference|: thesis Tables 6.1/6.2's "error rate"."""
        ref = self.ref_motion
        if ref == 0.0:
            return math.inf
        return abs(self.odom_motion - ref) / abs(ref)


Metres = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "m"})]


class KinematicParameters(schema.Declared, frozen=True):
    """The believed geometry odometry is computed with [m]."""

    ROOT: ClassVar[str] = "KinematicParameters"
    ERROR: ClassVar[type[Exception]] = CalibrationError
    wheel_radius_left: Metres
    wheel_radius_right: Metres
    track: Metres

    @property
    def wheel_radius(self) -> float:
        """Mean wheel radius [m] (robot.yaml's ``hardware.motors.wheel_radius``)."""
        return 0.5 * (self.wheel_radius_left + self.wheel_radius_right)


@dataclass(frozen=True)
class OdometryCorrection:
    """Multiplicative corrections: true / believed (1.0 = already right)."""

    left_scale: float
    right_scale: float
    track_scale: float
    residual_rms: float  # relative residual of the fit (0.01 = 1 %)
    segments: int

    @property
    def wheel_radius_scale(self) -> float:
        """Correction of the mean wheel radius."""
        return 0.5 * (self.left_scale + self.right_scale)

    def apply(self, params: KinematicParameters) -> KinematicParameters:
        """The proposed parameters: ``r_l' = k_l r_l``, ``r_r' = k_r r_r``, ``B' = k_b B``."""
        return KinematicParameters(
            params.wheel_radius_left * self.left_scale,
            params.wheel_radius_right * self.right_scale,
            params.track * self.track_scale,
        )


def estimate_correction(
    segments: list[SegmentMeasurement] | tuple[SegmentMeasurement, ...], track: float
) -> OdometryCorrection:
    """Least-squares ``(k_l, k_r, k_b)`` from straight runs and rotations (module docstring).

    ``track`` is the believed track [m] the odometry was computed with. Needs at least one
    straight run of ``MIN_STRAIGHT_M`` and one rotation of ``MIN_ROTATION_RAD``.
    """
    if not (math.isfinite(track) and track > 0):
        raise CalibrationError(f"track must be > 0 m, got {track!r}")
    straights = [
        s
        for s in segments
        if s.kind is SegmentKind.STRAIGHT and abs(s.odom_distance) >= MIN_STRAIGHT_M
    ]
    rotations = [
        s
        for s in segments
        if s.kind is SegmentKind.ROTATION and abs(s.odom_rotation) >= MIN_ROTATION_RAD
    ]
    if not straights:
        raise CalibrationError(
            f"no straight run of at least {MIN_STRAIGHT_M} m: the wheel radius is undetermined"
        )
    if not rotations:
        raise CalibrationError(
            f"no rotation of at least {MIN_ROTATION_RAD:.2f} rad: the track is undetermined"
        )
    rows: list[list[float]] = []
    rhs: list[float] = []
    for s in straights + rotations:
        # the measured wheel arcs (L, R) behind the odometry motion: d ∓ θ B / 2
        left, right = wheel_speeds(s.odom_distance, s.odom_rotation, track)
        size = max(abs(left), abs(right))
        if s.kind is SegmentKind.STRAIGHT:
            # d_ref = (k_l L + k_r R) / 2
            rows.append([0.5 * left / size, 0.5 * right / size, 0.0])
            rhs.append(s.ref_distance / size)
        # k_r R - k_l L - k_b B θ_ref = 0
        rows.append([-left / size, right / size, -track * s.ref_rotation / size])
        rhs.append(0.0)
    a = np.asarray(rows, dtype=np.float64)
    b = np.asarray(rhs, dtype=np.float64)
    solution, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if rank < 3:
        raise CalibrationError(
            "the segments do not determine both wheels and the track: drive straight runs "
            "and rotations of both signs"
        )
    k_l, k_r, k_b = (float(v) for v in solution)
    if not all(0.5 <= k <= 2.0 for k in (k_l, k_r, k_b)):
        raise CalibrationError(
            f"implausible correction (left {k_l:.3f}, right {k_r:.3f}, track {k_b:.3f}; "
            "allowed 0.5..2): was the robot localised throughout?"
        )
    residual = a @ solution - b
    rms = float(np.sqrt(np.mean(residual**2)))
    logger.info(
        "odometry correction from %d segments: left %.4f right %.4f track %.4f (rms %.4f)",
        len(rows),
        k_l,
        k_r,
        k_b,
        rms,
    )
    return OdometryCorrection(k_l, k_r, k_b, rms, len(straights) + len(rotations))


def format_table(title: str, segments: list[SegmentMeasurement]) -> str:
    """A plain-text table like thesis Tables 6.1/6.2: sections averaged, absolute error rate.

    The thesis timed the robot over a known distance; here the robot drives until its odometry
    reports the target and the scan matcher measures how far it really went, so the error rate
    is ``|odometry - scan match| / scan match`` (the same ratio: speed error = distance error).
    """
    header = (
        f"{'Sections':<11}{'Command':>12}{'Duration':>10}{'Odometry':>12}{'Scan match':>12}"
        f"{'Truth*':>9}{'Error rate':>11}"
    )
    lines = [title, header]
    for kind in (SegmentKind.STRAIGHT, SegmentKind.ROTATION):  # sections 1+3, then 2+4
        group = [s for s in segments if s.kind is kind]
        if not group:
            continue
        columns = [
            (abs(s.command), s.duration, abs(s.odom_motion), abs(s.ref_motion), s.error_rate)
            for s in group
        ]
        command, duration, odom, ref, error = np.mean(columns, axis=0)
        truths = [abs(s.truth_motion) for s in group if s.truth_motion is not None]
        truth = f"{np.mean(truths):.3f}" if len(truths) == len(group) else "-"
        straight = kind is SegmentKind.STRAIGHT
        unit, speed = ("m", "m/s") if straight else ("rad", "rad/s")
        name = "straight" if straight else "rotations"
        lines.append(
            f"{name:<11}{f'{command:.2f} {speed}':>12}{f'{duration:.2f} s':>10}"
            f"{f'{odom:.3f} {unit}':>12}{f'{ref:.3f} {unit}':>12}"
            f"{truth:>9}{100 * error:>10.3f}%"
        )
    lines.append("* ground truth, printed only as a check of the method; not used to estimate")
    return "\n".join(lines)
