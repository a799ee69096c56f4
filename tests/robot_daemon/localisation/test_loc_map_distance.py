"""The end points' distance to the map, compiled (`robot_daemon.localisation.map_distance`):
bit for bit the numpy code it replaced (`Localiser._to_map` and `_distance_to_map`, itself
checked against a masked lookup in `test_loc_speed_equivalence.py`), compiled and as plain
Python, on and off the map, on the synthetic office, the ISR map and after new obstacles; and
the see-through test's fraction that uses it, against the numpy code it replaced."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, load_map
from robot_daemon import jit
from robot_daemon.localisation import localiser as localiser_module
from robot_daemon.localisation import map_distance
from robot_daemon.localisation.localiser import Localiser
from robot_daemon.localisation.scan_matcher import subsample_points
from tests.robot_daemon.localisation.synthetic_office import (
    OFFICE_BOXES,
    office_grid,
    rasterise,
    utm_scan,
)
from tests.robot_daemon.localisation.test_loc_speed_equivalence import (
    distance_to_map_reference,
    trace_impossible_reference,
)

ISR = Path(__file__).resolve().parents[3] / "maps" / "isr_floor0.yaml"


def _old_end_points(
    loc: Localiser, points: np.ndarray, pose: Pose2D
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What `_hit_fraction` and `_update_map` computed before the kernel."""
    xs, ys = loc._to_map(points, pose)
    return xs, ys, loc._distance_to_map(xs, ys)


def _compare(loc: Localiser, points: np.ndarray, pose: Pose2D) -> int:
    """The kernel (compiled, plain) against the old numpy code; how many points were on the
    map (finite distance)."""
    want = _old_end_points(loc, points, pose)
    assert np.array_equal(want[2], distance_to_map_reference(loc, want[0], want[1]))
    g = loc._grid
    args = (
        np.ascontiguousarray(points),
        (pose.x, pose.y),
        (math.cos(pose.yaw), math.sin(pose.yaw)),
        loc._dist_padded,
        (g.origin_x, g.origin_y, g.resolution),
        (g.width, g.height),
    )
    for kernel in (
        map_distance.end_points_on_map,
        jit.python_function(map_distance.end_points_on_map),
    ):
        got = kernel(*args)
        for a, b in zip(got, want, strict=True):
            assert np.array_equal(a, b)
    assert np.array_equal(loc._end_points_on_map(points, pose)[2], want[2])
    return int(np.count_nonzero(np.isfinite(want[2])))


def test_end_points_on_the_office_equal_the_numpy_code() -> None:
    """Scans of the synthetic office at poses on and off it (points beyond each edge), and
    the same after new obstacles lowered the distance field."""
    rng = np.random.default_rng(41)
    loc = Localiser(office_grid())
    on_map = 0
    for lowered in (False, True):
        if lowered:
            loc._add_distance_obstacles(rng.uniform(1.0, 19.0, 40), rng.uniform(1.0, 13.0, 40))
        for _ in range(30):
            truth = Pose2D(rng.uniform(-3.0, 23.0), rng.uniform(-3.0, 17.0), rng.uniform(-4, 4))
            points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
            on_map += _compare(loc, points, truth)
            far = rng.uniform(-40.0, 40.0, (300, 2))  # many off the map
            on_map += _compare(loc, far, truth)
    assert on_map > 20_000


def test_end_points_on_the_isr_map_equal_the_numpy_code() -> None:
    """The tour's map (origin off zero, its own size): random poses on its free cells."""
    grid = load_map(ISR)
    loc = Localiser(grid)
    rng = np.random.default_rng(42)
    free = np.argwhere(grid.cells == FREE)
    angles = np.linspace(-2.35, 2.35, 1081)
    for k in rng.choice(free.shape[0], 20, replace=False):
        row, col = free[k]
        pose = Pose2D(
            grid.origin_x + (col + rng.uniform()) * grid.resolution,
            grid.origin_y + (row + rng.uniform()) * grid.resolution,
            float(rng.uniform(-math.pi, math.pi)),
        )
        ranges = rng.uniform(0.05, 30.0, angles.size)
        points = np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles)))
        assert _compare(loc, points, pose) > 0


@pytest.mark.parametrize("n", [0, 1, 7])
def test_hit_fraction_of_few_points(n: int) -> None:
    """No points: 0 (no kernel call); a few: the fraction of the old code."""
    rng = np.random.default_rng(43)
    loc = Localiser(office_grid())
    pose = Pose2D(5.0, 4.0, 0.2)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))[:n]
    _, _, distance = _old_end_points(loc, points, pose)
    want = 0.0 if n == 0 else np.count_nonzero(distance <= loc.config.hit_tolerance_m) / n
    assert loc._hit_fraction(points, pose) == want


def see_through_fraction_reference(
    loc: Localiser, points: np.ndarray, pose: Pose2D, crowded: bool
) -> float:
    """`Localiser.impossible_fraction` with ``see_through`` as numpy code before the kernels:
    the plain trace, `_to_map` and `_distance_to_map` of the beams through walls, `np.ptp`."""
    cfg = loc.config
    k = cfg.impossible_min_run
    mask, crossing = trace_impossible_reference(loc, points, pose)
    if mask.size == 0:
        return 0.0
    if crowded and k > 1:
        mask = localiser_module._long_runs(mask, k)
    if mask.any():
        pts = subsample_points(points, cfg.impossible_max_beams)
        xs, ys = loc._to_map(pts[mask], pose)
        landing = loc._distance_to_map(xs, ys)
        landed = landing <= cfg.see_through_landing_m
        sel = pts[mask]
        unit = sel / np.maximum(np.hypot(sel[:, 0], sel[:, 1]), 1e-9)[:, None]
        cx, cy = loc._to_map(unit * crossing[mask][:, None], pose)
        extent = math.hypot(float(np.ptp(cx)), float(np.ptp(cy)))
        if extent <= cfg.see_through_opening_m:
            if not crowded:
                landed |= landing <= cfg.see_through_moved_m
        elif crowded:
            landed[:] = False
        mask[np.flatnonzero(mask)[landed]] = False
    if k > 1 and mask.any():
        mask = localiser_module._long_runs(mask, k)
    return float(np.count_nonzero(mask)) / mask.size


@pytest.mark.parametrize("crowded", [False, True])
def test_see_through_fraction_equals_the_numpy_code(crowded: bool) -> None:
    """Scans of the office with a door the map has shut and without a desk the map has,
    judged at the truth and 0.05-0.5 m off it (beams through one opening, through several,
    landing on mapped surfaces or not): the see-through fraction of the numpy code."""
    door = np.array([[7.0, 7.9, 8.2, 8.2]])  # the map shuts the door at x 7-8.2
    grid = rasterise(np.vstack([OFFICE_BOXES, door]))
    world = np.array([box for box in OFFICE_BOXES if not np.array_equal(box, [3.0, 5.0, 3.8, 5.5])])
    loc = Localiser(grid)
    rng = np.random.default_rng(44)
    counted = allowed = 0
    for _ in range(40):
        truth = Pose2D(rng.uniform(1.0, 19.0), rng.uniform(1.0, 13.0), rng.uniform(-4, 4))
        points = loc._scan_points(utm_scan(world, truth, 0.0, rng))
        for sigma in (0.0, 0.05, 0.5):
            at = Pose2D(truth.x + rng.normal(0, sigma), truth.y + rng.normal(0, sigma), truth.yaw)
            want = see_through_fraction_reference(loc, points, at, crowded)
            got = loc.impossible_fraction(points, at, see_through=True, crowded=crowded)
            assert got == want
            plain = loc.impossible_fraction(points, at)
            counted += int(got > 0.0)
            allowed += int(got < plain)
    assert counted > 10 and allowed > 10  # beams counted, and beams let through
