"""The slide profile's kernel (`robot_daemon.localisation.slide_profile`): the map likelihood at
every pose equals `LikelihoodLevel.value_xy` of the numpy code it replaced bit for bit, compiled
and as plain Python; a run after the warm-up compiles nothing more.

`Localiser.slide_profile` as a whole is compared with its plain references in
`test_loc_speed_equivalence.py` (``test_slide_profile_equals_*``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon import jit
from robot_daemon.localisation import slide_profile
from robot_daemon.localisation.localiser import Localiser
from robot_daemon.localisation.scan_matcher import (
    PAD,
    LikelihoodLevel,
    ScanMatcher,
    ScanMatcherConfig,
    subsample_points,
)
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan


def _lattice(level: LikelihoodLevel) -> tuple[float, float, float, float, float, float]:
    h, w = level.field.shape
    inv = 1.0 / level.resolution
    offset = float(PAD - level.lattice_offset)
    return (level.origin_x, level.origin_y, inv, offset, w - 1.001, h - 1.001)


def value_at_poses_reference(
    level: LikelihoodLevel,
    points: np.ndarray,
    pose: tuple[float, float],
    direction: tuple[float, float],
    along: np.ndarray,
    yaw: np.ndarray,
) -> np.ndarray:
    """The numpy code the kernel replaced: the end points at every pose stacked (x and y,
    left to right) and `LikelihoodLevel.value_xy` of them."""
    px = pose[0] + along * direction[0]
    py = pose[1] + along * direction[1]
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    sx, sy = points[:, 0][None, :], points[:, 1][None, :]
    pxy = np.empty((2, along.size, points.shape[0]))
    np.add(px[:, None], c * sx, out=pxy[0])
    np.subtract(pxy[0], s * sy, out=pxy[0])
    np.add(py[:, None], s * sx, out=pxy[1])
    np.add(pxy[1], c * sy, out=pxy[1])
    out: np.ndarray = level.value_xy(pxy)
    return out


def test_likelihood_at_poses_equals_value_xy_compiled_and_plain() -> None:
    """Scans of the synthetic office at poses on and off the map (points clipped to the
    field's zero border), on every level of both wall models, after obstacles were added:
    `value_xy`'s M bit for bit, compiled and as plain Python."""
    rng = np.random.default_rng(31)
    grid = office_grid()
    loc = Localiser(grid)
    plain = jit.python_function(slide_profile.likelihood_at_poses)
    compared = 0
    for surface in ("cell_face", "cell_centre"):
        matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
        matcher.add_obstacles(rng.uniform(0.0, 20.0, 20), rng.uniform(0.0, 14.0, 20))
        for level in matcher.levels:
            for _ in range(6):
                truth = Pose2D(rng.uniform(-3.0, 23.0), rng.uniform(-3.0, 17.0), rng.uniform(-4, 4))
                scan = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
                points = np.ascontiguousarray(subsample_points(scan, int(rng.integers(20, 400))))
                along = rng.normal(0.0, 0.5, int(rng.integers(1, 40)))
                yaw = truth.yaw + rng.normal(0.0, 0.05, along.size)
                direction = (float(rng.normal()), float(rng.normal()))
                pose = (truth.x, truth.y)
                args = (
                    points,
                    pose,
                    direction,
                    along,
                    (np.cos(yaw), np.sin(yaw)),
                    level.corners,
                    _lattice(level),
                    level.field.shape[1],
                )
                want = value_at_poses_reference(level, points, pose, direction, along, yaw)
                assert np.array_equal(slide_profile.likelihood_at_poses(*args), want)
                assert np.array_equal(plain(*args), want)
                compared += int(np.count_nonzero(want))
    assert compared > 10_000  # mostly points near walls, not the zero border


def test_slide_profiles_after_the_warm_up_compile_nothing() -> None:
    """Slide profiles of every length the slide test asks for (1 to 10 offsets), at scans
    of the synthetic office, after `jit.warm_up`: no new signature."""
    jit.warm_up()
    kernel = slide_profile.likelihood_at_poses
    before = len(getattr(kernel, "signatures", ()))
    rng = np.random.default_rng(32)
    loc = Localiser(office_grid())
    for k in range(1, 11):
        truth = Pose2D(rng.uniform(1.0, 19.0), rng.uniform(1.0, 13.0), rng.uniform(-4, 4))
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        direction = np.array([math.cos(truth.yaw), math.sin(truth.yaw), 0.01])
        ratios = loc.slide_profile(points, truth, direction, 0.15 * np.arange(1, k + 1))
        assert ratios.shape == (2, k)
    assert len(getattr(kernel, "signatures", ())) == before
    if jit.ENABLED:
        assert before == 1


@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_slide_profile_after_a_matcher_swap_still_uses_one_specialisation(surface: str) -> None:
    """A matcher built anew (the learnt wall model's swap) hands the kernel its own corner
    table, of the same layout: no new signature."""
    jit.warm_up()
    kernel = slide_profile.likelihood_at_poses
    before = len(getattr(kernel, "signatures", ()))
    rng = np.random.default_rng(33)
    loc = Localiser(office_grid())
    loc.matcher = ScanMatcher(office_grid(), ScanMatcherConfig(surface=surface))
    truth = Pose2D(5.0, 4.0, 0.3)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
    loc.slide_profile(points, truth, np.array([1.0, 0.0, 0.0]), np.array([0.15, 0.3]))
    assert len(getattr(kernel, "signatures", ())) == before
