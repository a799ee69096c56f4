"""The localiser's fast paths equal their plain references, bit for bit (issue 12 speed work).

Each reference below is the readable version the fast code replaced (STYLE.md: keep a readable
reference in the tests when the fast one is hard to read); the tests compare them on random
poses and scans of the synthetic office, including rays and points that leave the map.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid, load_map
from robot_daemon import jit
from robot_daemon.localisation import localiser as localiser_module
from robot_daemon.localisation import sphere_trace
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig
from robot_daemon.localisation.relocaliser import Relocaliser, RelocaliserConfig
from robot_daemon.localisation.scan_matcher import (
    INLIER_M,
    PAD,
    LikelihoodLevel,
    MatchResult,
    ScanMatcher,
    ScanMatcherConfig,
    normal_information,
    subsample_points,
)
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import log_config, map_of
from tests.robot_daemon.localisation.synthetic_office import (
    OFFICE_BOXES,
    office_grid,
    rasterise,
    square,
    utm_scan,
)


def trace_impossible_reference(
    loc: Localiser, points: np.ndarray, pose: Pose2D
) -> tuple[np.ndarray, np.ndarray]:
    """The plain sphere-tracing loop of `Localiser._trace_impossible` (one pass per step,
    every bookkeeping step on every pass)."""
    cfg = loc.config
    pts = subsample_points(points, cfg.impossible_max_beams)
    out = np.zeros(pts.shape[0], dtype=bool)
    crossing = np.full(pts.shape[0], np.nan)
    sx, sy = pts[:, 0], pts[:, 1]
    r = np.hypot(sx, sy)
    limit = r - cfg.impossible_margin_m
    idx = np.flatnonzero(limit > 0.0)
    if idx.size == 0:
        return out, crossing
    g = loc._grid
    inv = 1.0 / g.resolution
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    rs = r[idx]
    dcol = (c * sx[idx] - s * sy[idx]) / rs * inv
    drow = (s * sx[idx] + c * sy[idx]) / rs * inv
    col0 = (pose.x - g.origin_x) * inv + 1.0
    row0 = (pose.y - g.origin_y) * inv + 1.0
    limit = limit[idx]
    dist = loc._wall_dist_padded
    wp = g.width + 2

    def lookup(tt: np.ndarray, dc: np.ndarray, dr: np.ndarray) -> np.ndarray:
        col = np.clip((col0 + tt * dc).astype(np.intp), 0, g.width + 1)
        row = np.clip((row0 + tt * dr).astype(np.intp), 0, g.height + 1)
        return dist[row * wp + col]

    t = np.zeros(idx.shape)
    for _ in range(cfg.impossible_max_steps):
        d = lookup(t, dcol, drow)
        hit = d < 0.5 * g.resolution
        if cfg.impossible_depth_m > 0.0 and hit.any():
            for frac in (0.5, 1.0):
                depth = t[hit] + frac * cfg.impossible_depth_m
                hit[hit] = lookup(depth, dcol[hit], drow[hit]) < 0.5 * g.resolution
        out[idx[hit]] = True
        crossing[idx[hit]] = t[hit]
        t += np.maximum(d - math.sqrt(2.0) * g.resolution, g.resolution)
        keep = ~hit & (t < limit)
        t, limit, dcol, drow, idx = t[keep], limit[keep], dcol[keep], drow[keep], idx[keep]
        if t.size == 0:
            break
    return out, crossing


def distance_to_map_reference(loc: Localiser, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """`Localiser._distance_to_map` with an explicit inside mask."""
    g = loc._grid
    col = np.floor((xs - g.origin_x) / g.resolution).astype(np.intp)
    row = np.floor((ys - g.origin_y) / g.resolution).astype(np.intp)
    inside = (row >= 0) & (row < g.height) & (col >= 0) & (col < g.width)
    out = np.full(xs.shape, np.inf)
    out[inside] = loc._dist_padded[(row[inside] + 1) * (g.width + 2) + col[inside] + 1]
    return out


def _poses(rng: np.random.Generator, n: int) -> list[Pose2D]:
    """Laser poses anywhere on the office floor (some inside walls), any heading."""
    return [
        Pose2D(
            float(rng.uniform(0.5, 19.5)), float(rng.uniform(0.5, 9.5)), float(rng.uniform(-4, 4))
        )
        for _ in range(n)
    ]


def _holed_office() -> OccupancyGrid:
    """The office with unknown patches and a gap in its outer wall: rays leave the map."""
    grid = office_grid()
    cells = grid.cells.copy()
    cells[60:90, 100:160] = UNKNOWN
    cells[:, :2] = FREE  # the west wall removed: rays run off the grid
    cells[100:104, 250:254] = OCCUPIED  # a lone block (shallower than impossible_depth_m)
    return grid.with_cells(cells)


@pytest.mark.parametrize("depth", [0.1, 0.0])
def test_fast_impossible_trace_equals_the_plain_loop(depth: float) -> None:
    rng = np.random.default_rng(3)
    for grid in (office_grid(), _holed_office()):
        loc = Localiser(grid, LocaliserConfig(impossible_depth_m=depth))
        for pose in _poses(rng, 25):
            # The true scan at one pose, matched at another: many rays pass through walls.
            scan = utm_scan(OFFICE_BOXES, pose, 0.0, rng)
            points = loc._scan_points(scan)
            wrong = Pose2D(pose.x + rng.normal(0, 1.0), pose.y + rng.normal(0, 1.0), pose.yaw)
            for at in (pose, wrong):
                mask, crossing = loc._trace_impossible(points, at)
                ref_mask, ref_crossing = trace_impossible_reference(loc, points, at)
                assert np.array_equal(mask, ref_mask)
                assert np.array_equal(crossing, ref_crossing, equal_nan=True)


def test_fast_impossible_trace_equals_the_plain_loop_from_off_the_map() -> None:
    """A laser off the map or on its border (the clipped lookup) and rays that leave it along
    an axis (the exit parameters' parallel case) trace as the plain loop does."""
    rng = np.random.default_rng(7)
    grid = _holed_office()
    loc = Localiser(grid)
    scan = utm_scan(OFFICE_BOXES, Pose2D(10.0, 5.0, 0.3), 0.0, rng)
    points = loc._scan_points(scan)
    axis = np.array([[8.0, 0.0], [0.0, 8.0], [-8.0, 0.0], [0.0, -8.0], [3.0, 0.0]])
    poses = [
        Pose2D(-1.0, 5.0, 0.0),  # west of the map, looking in
        Pose2D(21.0, 5.0, math.pi),  # east
        Pose2D(10.0, -0.7, math.pi / 2),  # south
        Pose2D(0.0, 0.0, 0.0),  # the corner cell
        Pose2D(-0.025, 5.0, 0.0),  # in the border's cells
        Pose2D(0.01, 9.99, -0.8),
        Pose2D(1.0, 5.0, 0.0),
        Pose2D(1.0, 5.0, math.pi / 2),
    ]
    for pose in poses:
        for pts in (points, axis):
            mask, crossing = loc._trace_impossible(pts, pose)
            ref_mask, ref_crossing = trace_impossible_reference(loc, pts, pose)
            assert np.array_equal(mask, ref_mask)
            assert np.array_equal(crossing, ref_crossing, equal_nan=True)


def test_fast_impossible_trace_equals_the_plain_loop_on_the_isr_map() -> None:
    """The tour's map (its rays run 30 m down corridors and off the map's edges)."""
    grid = load_map(Path(__file__).resolve().parents[3] / "maps" / "isr_floor0.yaml")
    loc = Localiser(grid)
    rng = np.random.default_rng(8)
    free = np.argwhere(grid.cells == FREE)
    angles = np.linspace(-2.35, 2.35, 400)
    for k in rng.choice(free.shape[0], 30, replace=False):
        row, col = free[k]
        pose = Pose2D(
            grid.origin_x + (col + rng.uniform()) * grid.resolution,
            grid.origin_y + (row + rng.uniform()) * grid.resolution,
            float(rng.uniform(-math.pi, math.pi)),
        )
        ranges = rng.uniform(0.5, 30.0, angles.size)  # many beams through walls, off the map
        points = np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles)))
        mask, crossing = loc._trace_impossible(points, pose)
        ref_mask, ref_crossing = trace_impossible_reference(loc, points, pose)
        assert np.array_equal(mask, ref_mask)
        assert np.array_equal(crossing, ref_crossing, equal_nan=True)


@pytest.mark.parametrize("compiled", [True, False])
def test_impossible_trace_compiled_or_plain_python_equals_the_plain_loop(
    compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The trace's kernel (`sphere_trace.trace_rays`) compiled and as its plain-Python function,
    on and off the map, with and without the depth test: the plain loop's flags and ranges."""
    if not compiled:
        monkeypatch.setattr(
            localiser_module, "trace_rays", jit.python_function(sphere_trace.trace_rays)
        )
    rng = np.random.default_rng(10)
    for depth in (0.1, 0.0):
        loc = Localiser(_holed_office(), LocaliserConfig(impossible_depth_m=depth))
        poses = [*_poses(rng, 12), Pose2D(-1.0, 5.0, 0.0), Pose2D(21.0, 5.0, math.pi)]
        for pose in poses:
            scan = utm_scan(OFFICE_BOXES, pose, 0.0, rng)
            points = loc._scan_points(scan)
            wrong = Pose2D(pose.x + rng.normal(0, 1.0), pose.y + rng.normal(0, 1.0), pose.yaw)
            for at in (pose, wrong):
                mask, crossing = loc._trace_impossible(points, at)
                ref_mask, ref_crossing = trace_impossible_reference(loc, points, at)
                assert np.array_equal(mask, ref_mask)
                assert np.array_equal(crossing, ref_crossing, equal_nan=True)


@pytest.mark.parametrize("unknown_edges", [True, False])
def test_impossible_trace_after_new_obstacles_equals_the_plain_loop(unknown_edges: bool) -> None:
    """New static obstacles lower the distance fields; the trace's step field made from them
    (`localiser._sphere_steps`) follows, whether the wall field is its own array (unknown
    edges as surfaces) or the matching one: the plain loop on the lowered field, flag for flag."""
    rng = np.random.default_rng(15)
    loc = Localiser(_holed_office(), LocaliserConfig(unknown_edges_are_surfaces=unknown_edges))
    xs, ys = rng.uniform(1.0, 19.0, 60), rng.uniform(1.0, 9.0, 60)  # boxes in the rooms
    loc._add_distance_obstacles(xs, ys)
    loc.matcher.add_obstacles(xs, ys)
    changed = 0
    for pose in _poses(rng, 20):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))
        mask, crossing = loc._trace_impossible(points, pose)
        ref_mask, ref_crossing = trace_impossible_reference(loc, points, pose)
        assert np.array_equal(mask, ref_mask)
        assert np.array_equal(crossing, ref_crossing, equal_nan=True)
        changed += int(mask.any())
    assert changed > 5  # the new boxes stand in the beams' way


def test_fast_distance_to_map_equals_the_masked_lookup() -> None:
    rng = np.random.default_rng(4)
    loc = Localiser(_holed_office())
    xs = rng.uniform(-5.0, 25.0, 5000)  # the office is 20 x 10 m: many points outside
    ys = rng.uniform(-5.0, 15.0, 5000)
    assert np.array_equal(loc._distance_to_map(xs, ys), distance_to_map_reference(loc, xs, ys))


def test_likelihood_value_is_the_interpolated_likelihood() -> None:
    rng = np.random.default_rng(5)
    loc = Localiser(office_grid())
    xs, ys = rng.uniform(-2.0, 22.0, 3000), rng.uniform(-2.0, 12.0, 3000)
    for level in loc.matcher.levels:
        assert np.array_equal(level.value(xs.copy(), ys.copy()), level.interpolate(xs, ys)[0])


def test_slide_profile_equals_its_plain_version() -> None:
    rng = np.random.default_rng(6)
    loc = Localiser(office_grid())
    level = loc.matcher.levels[1]
    for pose in _poses(rng, 10):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))
        direction = np.array([math.cos(pose.yaw), math.sin(pose.yaw), 0.0])
        offsets = np.array([0.1, 0.2, 0.3])
        fast = loc.slide_profile(points, pose, direction, offsets)
        # Plain: score every shifted (and turned) pose with `interpolate` and `mean`.
        pts = subsample_points(points, loc.config.slide_points)
        turn = loc.config.slide_turn_rad

        def score(p: Pose2D, pts: np.ndarray = pts) -> float:
            c, s = math.cos(p.yaw), math.sin(p.yaw)
            xs = p.x + c * pts[:, 0] - s * pts[:, 1]
            ys = p.y + s * pts[:, 0] + c * pts[:, 1]
            return float(level.interpolate(xs, ys)[0].mean())

        base = score(pose)
        if base <= 0.0:
            assert np.array_equal(fast, np.ones_like(fast))
            continue
        plain = np.array(
            [
                [
                    max(
                        score(
                            Pose2D(
                                pose.x + a * direction[0], pose.y + a * direction[1], pose.yaw + dy
                            )
                        )
                        for dy in (0.0, turn, -turn)
                    )
                    / base
                    for a in sign * offsets
                ]
                for sign in (1.0, -1.0)
            ]
        )
        assert np.allclose(fast, plain, rtol=1e-12, atol=0.0)


def test_slide_profile_equals_the_stacked_reference_bit_for_bit() -> None:
    """`Localiser.slide_profile` with the poses' end points written into one stacked array
    gives the ratios of the plain formulation (every pose's x and y as their own arrays,
    `interpolate_reference`), bit for bit, for slides with and without turning."""
    rng = np.random.default_rng(16)
    loc = Localiser(office_grid())
    level = loc.matcher.levels[1]
    t = loc.config.slide_turn_rad
    for pose in _poses(rng, 8):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))
        pts = subsample_points(points, loc.config.slide_points)
        for direction, offsets in (
            (np.array([0.6, 0.8, 0.0]), np.array([0.15, 0.3, 0.45])),
            (np.array([0.8, -0.6, 0.3]), np.array([0.15, 0.3, 0.45])),
            (np.array([0.8, -0.6, 0.0]), np.array([0.2, 0.4])),  # profiles of other lengths
        ):
            k = offsets.size
            along = np.concatenate(([0.0], np.repeat(offsets, 3), -np.repeat(offsets, 3)))
            turns = np.concatenate(([0.0], np.tile([0.0, t, -t], 2 * k)))
            yaw = pose.yaw + along * direction[2] + turns
            c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            px = (pose.x + along * direction[0])[:, None]
            py = (pose.y + along * direction[1])[:, None]
            xs = px + c * pts[:, 0] - s * pts[:, 1]
            ys = py + s * pts[:, 0] + c * pts[:, 1]
            scores = np.add.reduce(interpolate_reference(level, xs, ys)[0], axis=1) / pts.shape[0]
            expected = scores[1:].reshape(2, k, 3).max(axis=2) / scores[0]
            assert np.array_equal(loc.slide_profile(points, pose, direction, offsets), expected)


def test_scan_points_equal_the_column_stack_of_the_valid_beams() -> None:
    rng = np.random.default_rng(17)
    loc = Localiser(office_grid())
    scan = utm_scan(OFFICE_BOXES, Pose2D(10.0, 5.0, 0.2), 0.0, rng)
    ranges = scan.ranges.copy()
    ranges[::7] = 0.0  # below range_min
    ranges[::11] = 100.0  # beyond max_range_m
    scan = dataclasses.replace(scan, ranges=ranges)
    angles = scan.angles
    keep = (ranges >= scan.range_min) & (ranges <= min(scan.range_max, loc.config.max_range_m))
    r = ranges[keep].astype(np.float64)
    expected = np.column_stack((r * np.cos(angles)[keep], r * np.sin(angles)[keep]))
    assert np.array_equal(loc._scan_points(scan), expected)


# -- the background kidnap check -----------------------------------------------------------------

ROOM = np.vstack(
    [
        np.array([[0, 0, 6, 0.1], [0, 4.9, 6, 5], [0, 0, 0.1, 5], [5.9, 0, 6, 5]]),
        np.array([[1.0, 3.5, 2.2, 4.0], [4.4, 0.1, 5.9, 0.7]]),
        square(3.8, 2.6, 0.15),
    ]
)


class CountingSearch:
    """Wraps a relocaliser's search engine and counts the searches it runs."""

    def __init__(self, reloc: Relocaliser) -> None:
        self.engine = reloc.search_engine
        self.calls = 0
        original = self.engine.search

        def counted(*args: object, **kwargs: object) -> object:
            self.calls += 1
            return original(*args, **kwargs)  # type: ignore[arg-type]

        self.engine.search = counted  # type: ignore[method-assign]


def test_background_check_skips_the_search_only_when_no_place_can_fit_better() -> None:
    grid = rasterise(ROOM, size=(6.0, 5.0))
    loc = Localiser(grid)
    config = RelocaliserConfig(background_every_s=0.5, kidnap_min_range_m=0.0)
    reloc = Relocaliser(grid, loc, config)
    counter = CountingSearch(reloc)
    rng = np.random.default_rng(8)
    truth = Pose2D(2.0, 1.5, 0.4)
    for k in range(10):  # standing, tracked where it is: the scan fits, nothing to search
        now = 0.1 * (k + 1)
        assert reloc.check_standing(utm_scan(ROOM, truth, now, rng), truth, 0.0, now) is None
    here = reloc.verify(loc._scan_points(utm_scan(ROOM, truth, 1.0, rng)), truth, refine=False)
    assert reloc.cannot_be_beaten(here)
    assert counter.calls == 0
    # Tracked 1.2 m off (a kidnap the loss test missed): the fit is poor, the search runs
    # and finds the true place.
    tracked = Pose2D(3.2, 2.3, 0.4)
    found = None
    for k in range(10):
        now = 2.0 + 0.1 * k
        found = found or reloc.check_standing(utm_scan(ROOM, truth, now, rng), tracked, 0.0, now)
    assert counter.calls >= 1
    assert found is not None and found.pose.distance_to(truth) < 0.1


# -- the see-through test reuses the scan's trace ---------------------------------------------


class FreshTraces(Localiser):
    """A localiser that traces every beam every time it is asked (no reuse),
    counting the rays traced."""

    traces = 0

    def _trace_impossible(
        self, points: np.ndarray, pose: Pose2D, max_beams: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        beams = max_beams or self.config.impossible_max_beams
        self.traces += subsample_points(points, beams).shape[0]
        return self._trace_rays(points, pose, beams)


class CountedTraces(Localiser):
    """The shipped localiser, counting the rays it actually traces."""

    traces = 0

    def _trace_rays(
        self, points: np.ndarray, pose: Pose2D, max_beams: int
    ) -> tuple[np.ndarray, np.ndarray]:
        self.traces += subsample_points(points, max_beams).shape[0]
        return super()._trace_rays(points, pose, max_beams)


def test_see_through_reuses_the_trace_of_the_scan_and_estimates_alike() -> None:
    """A robot facing a door the map has closed, people around (the see-through test runs on
    most scans, crowded or not): every estimate equals that of tracing each time, with one
    trace per scan instead of two or three."""
    door = np.array([[7.0, 7.9, 8.2, 8.2]])
    truth = Pose2D(7.6, 6.6, math.pi / 2)
    grid = rasterise(np.vstack([OFFICE_BOXES, door]))
    people = [
        square(truth.x + 0.9 * math.cos(a), truth.y + 0.9 * math.sin(a), 0.15)
        for a in np.linspace(0.75 * math.pi, 2.25 * math.pi, 4)
    ]
    estimates = []
    for kind in (CountedTraces, FreshTraces):
        loc = kind(grid, LocaliserConfig(map_update=False))
        rng = np.random.default_rng(1)
        loc.on_odometry(truth, 0.0)
        loc.set_initial_pose(truth, 0.0, np.diag([0.02**2, 0.02**2, 0.01**2]))
        run = []
        for k in range(1, 16):
            walkers = people[: k % 5]  # 0 to 4 people: both tiers of the test
            world = np.vstack([OFFICE_BOXES, *walkers]) if walkers else OFFICE_BOXES
            pose = Pose2D(truth.x, truth.y, truth.yaw + 0.01 * k)
            loc.on_odometry(pose, 0.1 * k)
            est = loc.on_scan(utm_scan(world, pose, 0.1 * k, rng), 0.1 * k)
            run.append((est.pose, est.state, est.impossible, est.confidence, est.reason))
        estimates.append((run, loc.traces))
    (reused, traced_once), (fresh, traced_fresh) = estimates
    assert reused == fresh
    # One trace of the scan's beams per scan (and a quarter of them more where the probe
    # found one through a wall), not two or three.
    assert traced_once <= 15 * 1.25 * LocaliserConfig().impossible_max_beams
    assert traced_fresh > 20  # the see-through test asked again on most scans


def test_see_through_at_another_pose_traces_again() -> None:
    """Only the trace of the same points at the same pose is reused."""
    rng = np.random.default_rng(9)
    loc = CountedTraces(office_grid())
    fresh = FreshTraces(office_grid())
    pose = Pose2D(10.0, 5.0, 0.3)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))
    for at in (Pose2D(10.6, 5.3, 0.3), Pose2D(10.0, 5.0, 0.35)):
        first = loc.impossible_fraction(points, pose)
        assert first == fresh.impossible_fraction(points, pose)
        again = loc._see_through(points, at, 1.0, first)
        assert again == fresh.impossible_fraction(points, at, see_through=True)
        assert again != first  # the other pose gives another answer


def corner_table_reference(field: np.ndarray) -> np.ndarray:
    """`LikelihoodLevel.corners` rebuilt from the whole field: per node (i, j) the values at
    (i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1), zero beyond the field's last row/column."""
    h, w = field.shape
    nxt = np.zeros((h + 1, w + 1))
    nxt[:h, :w] = field
    return np.stack(
        (nxt[:h, :w], nxt[:h, 1:], nxt[1:, :w], nxt[1:, 1:]),
    ).reshape(4, h * w)


@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_obstacles_added_rebuild_the_corner_table_as_a_whole_rebuild_would(surface: str) -> None:
    """`add_obstacles` rebuilds only the corners around each new obstacle (speed); the table
    must equal one rebuilt from the whole field, on every level, obstacles at the map's edges
    and outside it included."""
    grid = office_grid()
    loc = Localiser(grid, LocaliserConfig(matcher=ScanMatcherConfig(surface=surface)))
    rng = np.random.default_rng(4)
    x0, y0 = grid.origin_x, grid.origin_y
    x1, y1 = x0 + grid.width * grid.resolution, y0 + grid.height * grid.resolution
    xs = np.concatenate((rng.uniform(x0, x1, 40), [x0, x1 - 1e-3, x0 + 0.01, x1 + 1.0, x0 - 0.2]))
    ys = np.concatenate((rng.uniform(y0, y1, 40), [y0, y1 - 1e-3, y1 - 0.01, y0 + 0.5, y0 + 0.5]))
    loc.matcher.add_obstacles(xs, ys)
    for level in loc.matcher.levels:
        assert np.array_equal(level.corners, corner_table_reference(level.field))
    fresh = ScanMatcher(grid, loc.matcher.config).levels
    assert all(
        not np.array_equal(a.field, b.field) for a, b in zip(loc.matcher.levels, fresh, strict=True)
    )


def _same_match(a: MatchResult, b: MatchResult) -> bool:
    """Two match results equal bit for bit (pose, H, score, counts, information)."""
    return (
        (a.pose.x, a.pose.y, a.pose.yaw) == (b.pose.x, b.pose.y, b.pose.yaw)
        and np.array_equal(a.hessian, b.hessian)
        and a.score == b.score
        and (a.n_points, a.n_inliers) == (b.n_points, b.n_inliers)
        and np.array_equal(a.normal_info, b.normal_info)
    )


def _starts_around(prior: Pose2D, sxy: float, syaw: float) -> list[Pose2D]:
    """`Localiser._match_from_starts`'s 25 starts, and two off the map."""
    starts = [
        Pose2D(prior.x + dx, prior.y + dy, prior.yaw + dyaw)
        for dyaw in (0.0, -0.5 * syaw, 0.5 * syaw, -syaw, syaw)
        for dx, dy in ((0.0, 0.0), (sxy, 0.0), (-sxy, 0.0), (0.0, sxy), (0.0, -sxy))
    ]
    return [*starts, Pose2D(-50.0, 3.0, 0.2), Pose2D(prior.x, 500.0, -3.0)]


@pytest.mark.parametrize("start_level", [None, 1, 0])
@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_match_many_equals_one_match_per_start(surface: str, start_level: int | None) -> None:
    """`ScanMatcher.match_many` (the starts' iterations stacked) gives every start the result
    `match` gives it alone, on scans of the synthetic office from poses 0.15 m and 10 degrees
    off (starts that converge at different iterations, and starts off the map)."""
    rng = np.random.default_rng(12)
    grid = office_grid()
    matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
    loc = Localiser(grid)
    for truth in _poses(rng, 4):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        prior = Pose2D(truth.x + 0.1, truth.y - 0.1, truth.yaw + math.radians(10.0))
        starts = _starts_around(prior, 0.15, math.radians(10.0))
        many = matcher.match_many(points, starts, start_level)
        assert len(many) == len(starts)
        for start, result in zip(starts, many, strict=True):
            assert _same_match(result, matcher.match(points, start, start_level))


@pytest.mark.parametrize("keep", [0, 1, 3])
@pytest.mark.parametrize("start_level", [None, 1])
@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_match_best_equals_match_manys_kept_starts_and_best(
    surface: str, start_level: int | None, keep: int
) -> None:
    """`ScanMatcher.match_best` (only the results it returns evaluated in full) gives the first
    ``keep`` starts and the best-scoring of the rest (the first of equals) `match_many`'s
    results bit for bit, whichever start wins (the prior's own, another, starts off the map
    among the rest), on a blank scan too."""
    rng = np.random.default_rng(14)
    grid = office_grid()
    matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
    loc = Localiser(grid)
    winners = set()
    for truth in _poses(rng, 5):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        prior = Pose2D(truth.x + 0.1, truth.y - 0.1, truth.yaw + math.radians(10.0))
        starts = _starts_around(prior, 0.15, math.radians(10.0))
        starts = [*starts[-2:], *starts[:-2]]  # the two off the map first
        many = matcher.match_many(points, starts, start_level)
        rest = many[keep:]
        top = max(r.score for r in rest)
        winner = next(k for k, r in enumerate(rest) if r.score == top)
        winners.add(winner)
        best = matcher.match_best(points, starts, start_level, keep)
        assert len(best) == keep + 1
        for got, want in zip(best, [*many[:keep], rest[winner]], strict=True):
            assert _same_match(got, want)
    assert len(winners) > 1  # not always the same start
    blank = np.zeros((0, 2))
    for got, want in zip(
        matcher.match_best(blank, starts[:3], None, 1),
        matcher.match_many(blank, starts[:2]),
        strict=True,
    ):
        assert _same_match(got, want)
    with pytest.raises(ValueError, match="keep"):
        matcher.match_best(points, starts[:2], None, 2)


@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_starts_stopped_on_a_coarse_level_and_finished_equal_match_many(surface: str) -> None:
    """`ScanMatcher.coarse_many` then `finish` of some of the starts gives those starts
    `match_many`'s results bit for bit (headings carried on unwrapped: starts across ±pi), and
    `coarse_many`'s scores are `level_score`'s at its poses."""
    rng = np.random.default_rng(13)
    grid = office_grid()
    matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
    loc = Localiser(grid)
    for k, truth in enumerate(_poses(rng, 4)):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        yaw = math.pi - 0.05 if k == 0 else truth.yaw + math.radians(10.0)  # across +-pi
        prior = Pose2D(truth.x + 0.1, truth.y - 0.1, yaw)
        starts = _starts_around(prior, 0.15, math.radians(10.0))
        many = matcher.match_many(points, starts)
        coarse = matcher.coarse_many(points, starts, 1)
        for j in range(len(starts)):
            # (to the last bits: the pose's heading is wrapped, the stack's is not)
            score = matcher.level_score(points, coarse.pose(j), 1)
            assert coarse.scores[j] == pytest.approx(score, rel=1e-12, abs=1e-15)
        finish = [0, 3, 7, len(starts) - 1]
        for j, result in zip(finish, matcher.finish(points, coarse, finish), strict=True):
            assert _same_match(result, many[j])


def wide_heading_reference(
    loc: Localiser, points: np.ndarray, predicted: Pose2D, cov: np.ndarray, start: int | None
) -> MatchResult:
    """The prediction's match, `_nearest_mode`, then the four heading starts matched apart
    (`Localiser._wide_heading_match` before its matches were stacked)."""
    result = loc.matcher.match(points, predicted, start)
    result = loc._nearest_mode(points, result, predicted, cov)
    syaw = math.sqrt(float(cov[2, 2]))
    starts = [
        Pose2D(predicted.x, predicted.y, predicted.yaw + k * syaw) for k in (-1, -0.5, 0.5, 1)
    ]
    best = result
    for other in loc.matcher.match_many(points, starts):
        if other.score > best.score:
            best = other
    fine = subsample_points(points, loc.config.matcher.max_points)
    if best is result or loc._hit_fraction(fine, best.pose) < loc.config.lost_confidence:
        return result
    return best


@pytest.mark.parametrize("start", [None, 2, 1])
def test_wide_heading_match_with_every_start_finished_equals_the_matches_apart(
    start: int | None,
) -> None:
    """With ``heading_starts_finished`` 4 the prediction's match and the four heading starts
    iterated as one stack give the matches made apart bit for bit (from 10 and 20 degrees off
    the truth, where a start wins, and on the truth, where the prediction's match does)."""
    rng = np.random.default_rng(14)
    loc = Localiser(office_grid(), LocaliserConfig(heading_starts_finished=4))
    cov = np.diag([0.15**2, 0.15**2, 0.3**2])
    won = 0
    for truth in _poses(rng, 4):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        for off in (0.0, 10.0, -20.0):
            predicted = Pose2D(truth.x + 0.05, truth.y, truth.yaw + math.radians(off))
            ref = wide_heading_reference(loc, points, predicted, cov, start)
            fast = loc._wide_heading_match(points, predicted, cov, start)
            assert _same_match(fast, ref)
            won += fast.pose.yaw != loc.matcher.match(points, predicted, start).pose.yaw
    assert won > 0  # some heading start beat the prediction's own match


class OneStartAtATime(Localiser):
    """The first match from its starts one by one: the loop `_match_from_starts` had."""

    def _match_from_starts(self, points: np.ndarray, prior: Pose2D, cov: np.ndarray) -> MatchResult:
        sxy = 0.5 * math.sqrt(max(float(cov[0, 0]), float(cov[1, 1])))
        syaw = math.sqrt(max(float(cov[2, 2]), 0.0))
        best = self.matcher.match(points, prior)
        for start in _starts_around(prior, sxy, syaw)[1:25]:
            result = self.matcher.match(points, start)
            if result.score > best.score:
                best = result
        return best


def test_first_matches_from_stacked_starts_estimate_as_one_by_one() -> None:
    """A localiser re-set every few scans (each time 0.2 m and 8 degrees off, as a person sets
    a pose): every estimate, covariance and state equals that of matching the starts one by
    one."""
    grid = office_grid()
    runs = []
    for kind in (Localiser, OneStartAtATime):
        loc = kind(grid)
        scan_rng = np.random.default_rng(6)
        run = []
        for k, truth in enumerate(_poses(np.random.default_rng(7), 12)):
            loc.on_odometry(truth, float(k))
            if k % 3 == 0:
                off = Pose2D(truth.x + 0.2, truth.y - 0.1, truth.yaw - math.radians(8.0))
                loc.set_initial_pose(off, float(k))
            est = loc.on_scan(utm_scan(OFFICE_BOXES, truth, float(k), scan_rng), float(k) + 0.5)
            assert est.pose is not None
            run.append((est.pose, est.state, est.score, est.covariance.tolist(), est.reason))
        runs.append(run)
    assert runs[0] == runs[1]


@pytest.mark.realdata
def test_match_many_equals_one_match_per_start_on_a_real_log() -> None:
    """The same on the Intel lab's log (a map of its first 300 scans, every second one, in the
    log's cell-centre convention), from 25 starts around ten other scans' logged poses."""
    path = (
        Path(__file__).resolve().parents[3].parent / "shared/data/laser_logs/intel-corrected.log.gz"
    )
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)[:300]
    loc = Localiser(map_of(records[::2]), log_config())
    for record in records[1::30]:
        points = loc._scan_points(record.scan)
        starts = _starts_around(record.pose, 0.15, math.radians(10.0))
        for start, result in zip(starts, loc.matcher.match_many(points, starts), strict=True):
            assert _same_match(result, loc.matcher.match(points, start))


def interpolate_reference(level: LikelihoodLevel, px: np.ndarray, py: np.ndarray) -> tuple:
    """Bilinear M and ∇M with numpy's clip, floor and one gather per corner."""
    inv = 1.0 / level.resolution
    h, w = level.field.shape
    u = np.clip((px - level.origin_x) * inv + (PAD - level.lattice_offset), 0.0, w - 1.001)
    v = np.clip((py - level.origin_y) * inv + (PAD - level.lattice_offset), 0.0, h - 1.001)
    j, i = np.floor(u).astype(np.intp), np.floor(v).astype(np.intp)
    fx, fy = u - j, v - i
    m00, m01, m10, m11 = (level.corners[c][i * w + j] for c in range(4))
    a, b = m00 + fx * (m01 - m00), m10 + fx * (m11 - m10)
    return a + fy * (b - a), (m01 - m00 + fy * ((m11 - m10) - (m01 - m00))) * inv, (b - a) * inv


def normal_information_reference(
    m: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    rx: np.ndarray,
    ry: np.ndarray,
    tensor: np.ndarray,
) -> tuple[np.ndarray, int]:
    """`scan_matcher.normal_information` with boolean masks and the tensor at every point
    (`LikelihoodLevel.tensor_at`), the normals computed everywhere."""
    g = np.hypot(gx, gy)
    sel = (m > INLIER_M) & (g > 1e-9)
    n = int(np.count_nonzero(sel))
    if n == 0:
        return np.zeros((3, 3)), 0
    inv = 1.0 / g[sel]
    nx, ny = gx[sel] * inv, gy[sel] * inv
    t = tensor[sel].astype(np.float64)
    have = ~np.isnan(t[:, 0])
    txx = np.where(have, t[:, 0], nx * nx)
    txy = np.where(have, t[:, 1], nx * ny)
    tyy = np.where(have, t[:, 2], ny * ny)
    jx, jy = -ry[sel], rx[sel]
    ax, ay = txx * jx + txy * jy, txy * jx + tyy * jy
    a, b, d = float(txx.sum()), float(txy.sum()), float(tyy.sum())
    e, f, c = float(ax.sum()), float(ay.sum()), float((jx * ax + jy * ay).sum())
    return np.array([[a, b, e], [b, d, f], [e, f, c]]), n


def test_normal_information_equals_the_plain_one() -> None:
    """`normal_information` (each inlier's summands in one compiled loop, the tensor looked up
    at the inliers only) bit for bit the plain version, with the tensor known at every inlier,
    at some (new obstacles: NaN rows) and at none (a level without a tensor)."""
    grid = office_grid()
    matcher = ScanMatcher(grid)
    level = matcher.levels[0]
    full = level.tensor
    assert full is not None
    holed = full.copy()
    holed[::3] = np.nan
    rng = np.random.default_rng(5)
    loc = Localiser(grid)
    counts = []
    for truth in _poses(rng, 6):
        points = subsample_points(loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng)), 400)
        c, s = math.cos(truth.yaw), math.sin(truth.yaw)
        rx = c * points[:, 0] - s * points[:, 1]
        ry = s * points[:, 0] + c * points[:, 1]
        mxy = np.stack((rx + truth.x, ry + truth.y))
        grad = np.empty_like(mxy)
        m = level.interpolate_xy(mxy, grad)
        for table in (full, holed, None):
            level.tensor = table
            tensor = level.tensor_at(mxy[0], mxy[1])
            want = normal_information_reference(m, grad[0], grad[1], rx, ry, tensor)
            info, n = normal_information(m, grad[0], grad[1], rx, ry, mxy, level)
            assert n == want[1]
            assert np.array_equal(info, want[0])
            counts.append(n)
    level.tensor = full
    assert min(counts) > 0


def match_reference(
    matcher: ScanMatcher, points: np.ndarray, initial: Pose2D, start_level: int | None = None
) -> MatchResult:
    """`ScanMatcher.match` as plain numpy: the Gauss-Newton step from arrays (H, g), the
    damping added to H's diagonal in place."""
    cfg = matcher.config
    fine = subsample_points(points, cfg.max_points)
    px, py, yaw = initial.x, initial.y, initial.yaw
    n_levels = len(matcher.levels)
    first = n_levels - 1 if start_level is None else start_level
    for li in range(first, -1, -1):
        level = matcher.levels[li]
        pts = fine if li == 0 else subsample_points(fine, max(cfg.max_points >> li, 30))
        sx, sy = pts[:, 0].copy(), pts[:, 1].copy()
        n_iter = cfg.iterations[n_levels - 1 - li]
        n_max = max(n_iter, cfg.fine_max_iterations) if li == 0 else n_iter
        converged = False
        for it in range(n_max + (1 if li == 0 else 0)):
            c, s = math.cos(yaw), math.sin(yaw)
            rx, ry = c * sx - s * sy, s * sx + c * sy
            m, gx, gy = interpolate_reference(level, rx + px, ry + py)
            jt = gy * rx - gx * ry
            jac = np.stack((gx, gy, jt))
            h = jac @ jac.T
            if li == 0 and (it == n_max or (it >= n_iter and converged)):
                tensor = level.tensor_at(rx + px, ry + py)
                info, n_in = normal_information_reference(m, gx, gy, rx, ry, tensor)
                score = float(np.add.reduce(m)) / m.size
                return MatchResult(Pose2D(px, py, yaw), h, score, len(fine), info, n_in)
            r = 1.0 - m
            g = np.array([np.add.reduce(gx * r), np.add.reduce(gy * r), np.add.reduce(jt * r)])
            lam = cfg.damping * (h[0, 0] + h[1, 1] + h[2, 2]) / 3.0 + 1e-9
            h[np.diag_indices(3)] += lam
            (a, b, cc), (_, d, e), (_, _, f) = h
            co0, co1, co2 = d * f - e * e, cc * e - b * f, b * e - cc * d
            det = a * co0 + b * co1 + cc * co2
            if not abs(det) > 1e-300:
                dx = dy = dth = 0.0
            else:
                dx = (g[0] * co0 + g[1] * co1 + g[2] * co2) / det
                dy = (g[0] * co1 + g[1] * (a * f - cc * cc) + g[2] * (b * cc - a * e)) / det
                dth = (g[0] * co2 + g[1] * (b * cc - a * e) + g[2] * (a * d - b * b)) / det
            dth = max(-cfg.max_angular_step, min(cfg.max_angular_step, dth))
            converged = abs(dx) + abs(dy) < cfg.converged_m and abs(dth) < cfg.converged_rad
            px, py, yaw = float(px + dx), float(py + dy), float(yaw + dth)
    raise AssertionError("the finest level always ends the match")


@pytest.mark.parametrize("shape", [(3000,), (7, 400)])
def test_stacked_interpolation_equals_the_plain_one(shape: tuple[int, ...]) -> None:
    """`LikelihoodLevel.interpolate_xy` and `value_xy` (x and y through each numpy call
    together, a point's four corners one row of the table) give `interpolate_reference`'s M and
    ∇M bit for bit: one scan's points, and a stack of starts' as `match_many` has them, on and
    off the field, on every level, after obstacles were added."""
    rng = np.random.default_rng(14)
    grid = office_grid()
    for surface in ("cell_face", "cell_centre"):
        matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
        matcher.add_obstacles(rng.uniform(0.0, 20.0, 30), rng.uniform(0.0, 10.0, 30))
        for level in matcher.levels:
            pxy = np.stack((rng.uniform(-2.0, 22.0, shape), rng.uniform(-2.0, 12.0, shape)))
            m_ref, gx_ref, gy_ref = interpolate_reference(level, pxy[0], pxy[1])
            grad = np.empty_like(pxy)
            assert np.array_equal(level.interpolate_xy(pxy, grad), m_ref)
            assert np.array_equal(grad[0], gx_ref)
            assert np.array_equal(grad[1], gy_ref)
            assert np.array_equal(level.value_xy(pxy), m_ref)


@pytest.mark.parametrize("start_level", [None, 1, 0])
@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_match_equals_its_plain_numpy_version(surface: str, start_level: int | None) -> None:
    """`ScanMatcher.match` (its step in Python floats, one gather for the four corners) gives
    the plain numpy version's result bit for bit, from good and poor starts and off the map."""
    rng = np.random.default_rng(3)
    grid = office_grid()
    matcher = ScanMatcher(grid, ScanMatcherConfig(surface=surface))
    loc = Localiser(grid)
    for truth in _poses(rng, 5):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        prior = Pose2D(truth.x - 0.12, truth.y + 0.05, truth.yaw + math.radians(6.0))
        for start in _starts_around(prior, 0.15, math.radians(10.0))[::4]:
            expected = match_reference(matcher, points, start, start_level)
            assert _same_match(matcher.match(points, start, start_level), expected)


@pytest.mark.realdata
def test_match_equals_its_plain_numpy_version_on_a_real_log() -> None:
    """The same on the Intel lab's log (cell-centre map of its first 300 scans)."""
    path = (
        Path(__file__).resolve().parents[3].parent / "shared/data/laser_logs/intel-corrected.log.gz"
    )
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)[:300]
    loc = Localiser(map_of(records[::2]), log_config())
    for record in records[1::15]:
        points = loc._scan_points(record.scan)
        for start_level in (None, 1):
            expected = match_reference(loc.matcher, points, record.pose, start_level)
            assert _same_match(loc.matcher.match(points, record.pose, start_level), expected)


# -- the impossible fraction ---------------------------------------------------------------------


def impossible_fraction_reference(loc: Localiser, points: np.ndarray, pose: Pose2D) -> float:
    """`Localiser.impossible_fraction` without ``see_through``: one plain trace of every beam,
    the runs of at least ``impossible_min_run`` counted."""
    mask, _ = trace_impossible_reference(loc, points, pose)
    if mask.size == 0:
        return 0.0
    k = loc.config.impossible_min_run
    if k > 1 and mask.any():
        mask = localiser_module._long_runs(mask, k)
    return float(np.count_nonzero(mask)) / mask.size


@pytest.mark.parametrize("depth", [0.1, 0.0])
def test_impossible_fraction_equals_the_plain_loop(depth: float) -> None:
    """Scans at the truth (most fractions 0) and 0.05-1 m off (runs through walls): the
    fraction of the plain loop, and the trace kept for `_see_through` is its trace."""
    rng = np.random.default_rng(5)
    zero = counted = 0
    for grid in (office_grid(), _holed_office()):
        loc = Localiser(grid, LocaliserConfig(impossible_depth_m=depth))
        for pose in _poses(rng, 25):
            points = loc._scan_points(utm_scan(OFFICE_BOXES, pose, 0.0, rng))
            for sigma in (0.0, 0.05, 0.3, 1.0):
                at = Pose2D(pose.x + rng.normal(0, sigma), pose.y + rng.normal(0, sigma), pose.yaw)
                fraction = loc.impossible_fraction(points, at)
                assert fraction == impossible_fraction_reference(loc, points, at)
                ref_mask, ref_crossing = trace_impossible_reference(loc, points, at)
                assert loc._last_trace is not None
                assert np.array_equal(loc._last_trace[3], ref_mask)
                assert np.array_equal(loc._last_trace[4], ref_crossing, equal_nan=True)
                zero += int(fraction == 0.0)
                counted += int(fraction > 0.0)
    assert zero > 20 and counted > 20  # both kinds of scan
