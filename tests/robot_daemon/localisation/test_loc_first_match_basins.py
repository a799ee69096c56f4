"""The first match after a set pose, pruned by level-1 basins (`Localiser._match_from_starts`,
issue 12's p99): the same pick as matching all 25 starts to the finest level, and the matcher's
pieces it is made of equal to their references bit for bit."""

from __future__ import annotations

import math
from pathlib import Path

import msgspec
import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon import jit
from robot_daemon.localisation import match_kernels
from robot_daemon.localisation.localiser import (
    BASIN_RAD,
    Localiser,
    LocaliserConfig,
    coarse_basins,
)
from robot_daemon.localisation.scan_matcher import (
    TERM_ROWS,
    CoarseStarts,
    MatchResult,
    ScanMatcher,
    ScanMatcherConfig,
    subsample_points,
)
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import log_config, map_of
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"


def _same_match(a: MatchResult, b: MatchResult) -> bool:
    """Two match results equal bit for bit (pose, H, score, counts, information)."""
    return (
        (a.pose.x, a.pose.y, a.pose.yaw) == (b.pose.x, b.pose.y, b.pose.yaw)
        and np.array_equal(a.hessian, b.hessian)
        and a.score == b.score
        and (a.n_points, a.n_inliers) == (b.n_points, b.n_inliers)
        and np.array_equal(a.normal_info, b.normal_info)
    )


def _every_start(loc: Localiser) -> Localiser:
    """A copy of ``loc``'s settings that matches all 25 starts to the finest level."""
    config = msgspec.structs.replace(loc.config, initial_basins_finished=25)
    out = Localiser.__new__(Localiser)
    out.__dict__ = dict(loc.__dict__, config=config)
    return out


def _person_priors(truth: Pose2D) -> list[Pose2D]:
    """Poses a person might set around ``truth``: on it, and 0.2-0.3 m and 5-10 degrees off."""
    return [
        truth,
        Pose2D(truth.x + 0.2, truth.y - 0.1, truth.yaw - math.radians(8.0)),
        Pose2D(truth.x - 0.3, truth.y + 0.2, truth.yaw + math.radians(5.0)),
        Pose2D(truth.x + 0.1, truth.y + 0.3, truth.yaw + math.radians(10.0)),
    ]


def test_level_scores_equal_level_score_bit_for_bit() -> None:
    """`ScanMatcher._level_scores` (every pose's end points in one interpolation) gives each
    pose `_level_score`'s value (`level_score`'s), on each level, on and off the map."""
    rng = np.random.default_rng(3)
    grid = office_grid()
    matcher = ScanMatcher(grid, ScanMatcherConfig())
    loc = Localiser(grid)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, Pose2D(5.0, 4.0, 0.3), 0.0, rng))
    x = rng.uniform(-2.0, 22.0, 9)
    y = rng.uniform(-2.0, 12.0, 9)
    yaw = rng.uniform(-7.0, 7.0, 9)
    fine = subsample_points(points, matcher.config.max_points)
    for level in range(len(matcher.levels)):
        scores = matcher._level_scores(fine, x, y, yaw, level)
        for k in range(9):  # (the heading unwrapped, as `coarse_many` iterates it)
            assert scores[k] == matcher._level_score(
                fine, float(x[k]), float(y[k]), float(yaw[k]), level
            )


def test_finish_best_equals_the_best_of_finish() -> None:
    """`ScanMatcher.finish_best` of some starts is `finish`'s best-scoring result (the first
    of equals), bit for bit."""
    rng = np.random.default_rng(4)
    grid = office_grid()
    loc = Localiser(grid)
    matcher = loc.matcher
    for truth in (Pose2D(4.0, 3.0, 0.5), Pose2D(12.0, 6.0, -2.0)):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        starts = [
            Pose2D(truth.x + dx, truth.y + dy, truth.yaw + dyaw)
            for dx, dy, dyaw in (
                (0.0, 0.0, 0.0),
                (0.3, 0.0, 0.1),
                (0.0, -0.3, -0.2),
                (1.0, 1.0, 1.0),
            )
        ]
        coarse = matcher.coarse_many(points, starts, 1)
        for ks in ([0], [1, 3], [0, 1, 2, 3]):
            results = matcher.finish(points, coarse, ks)
            best = results[0]
            for r in results[1:]:
                if r.score > best.score:
                    best = r
            assert _same_match(matcher.finish_best(points, coarse, ks), best)


def test_basins_group_starts_within_a_cell_and_the_turn() -> None:
    """`coarse_basins`: best score first; a start joins the basin of a better start within
    the radius in position and in heading (wrapped), else opens its own."""
    starts = CoarseStarts(
        1,
        np.array([0.0, 0.05, 0.0, 0.3, 0.0]),
        np.array([0.0, 0.0, 0.0, 0.0, 0.0]),
        np.array([0.0, 0.01, 0.1, 0.0, math.tau + 0.01]),
        [0.5, 0.9, 0.7, 0.6, 0.4],
    )
    assert coarse_basins(starts, 0.1, BASIN_RAD) == [[1, 0, 4], [2], [3]]


def test_first_match_keeping_every_basin_is_the_25_start_match() -> None:
    """Where the starts reach no more basins than are kept, the pruned first match is the
    25-start match bit for bit; on the synthetic office, from a person's set poses, it picks
    the same pose (the pick lies in a kept basin)."""
    rng = np.random.default_rng(8)
    loc = Localiser(office_grid(), LocaliserConfig())
    every = _every_start(loc)
    cov = np.diag([0.3**2, 0.3**2, loc.config.initial_sigma_rad**2])
    compared = 0
    for truth in (Pose2D(4.0, 3.0, 0.5), Pose2D(12.0, 6.0, -2.0), Pose2D(17.0, 2.5, 2.8)):
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        for prior in _person_priors(truth):
            assert _same_match(
                loc._match_from_starts(points, prior, cov),
                every._match_from_starts(points, prior, cov),
            )
            compared += 1
    assert compared == 12


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["intel", "freiburg-campus"])
def test_first_match_on_real_logs_picks_the_25_start_optimum(name: str) -> None:
    """On real logs' scans (the Freiburg campus: outdoor, sparse returns, the log whose
    re-set poses made the p99), from a person's set poses around the logged ones, the pruned
    first match picks the 25-start match's optimum (within 1 cm and 0.5 degree) or one that
    fits the scan at least as well; and on most of them the very same result."""
    path = LOGS / f"{name}-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)
    loc = Localiser(map_of(records[::2]), log_config())
    every = _every_start(loc)
    cov = np.diag([0.3**2, 0.3**2, loc.config.initial_sigma_rad**2])
    same = total = 0
    for record in records[1 :: max(1, len(records) // 12)]:
        points = loc._scan_points(record.scan)
        if points.shape[0] < 10:
            continue
        for prior in _person_priors(record.pose):
            gated = loc._gate_through_walls(points, prior, cov)
            fast = loc._match_from_starts(gated, prior, cov)
            full = every._match_from_starts(gated, prior, cov)
            total += 1
            same += _same_match(fast, full)
            near = fast.pose.distance_to(full.pose) < 0.01 and abs(
                math.remainder(fast.pose.yaw - full.pose.yaw, math.tau)
            ) < math.radians(0.5)
            assert near or fast.score >= full.score, (record.pose, prior, fast, full)
    assert total >= 40
    assert same >= 0.9 * total


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("shared", [True, False])
def test_starts_iterated_in_one_call_equal_one_call_per_start(compiled: bool, shared: bool) -> None:
    """`match_kernels.gauss_newton_starts` (compiled, or its plain Python) gives every start
    the state, terms and stop of `gauss_newton_level` called for it alone, on the finest level
    (terms kept per start) and a coarse one (one scratch, ``shared``), starts off the map
    too."""
    rng = np.random.default_rng(11)
    loc = Localiser(office_grid())
    matcher = loc.matcher
    truth = Pose2D(6.0, 4.0, 1.0)
    points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
    sxy = np.ascontiguousarray(subsample_points(points, matcher.config.max_points).T)
    states = np.array(
        [
            (truth.x + 0.2, truth.y, truth.yaw + 0.1),
            (truth.x, truth.y - 0.3, truth.yaw - 0.15),
            (-50.0, 3.0, 0.2),
            (truth.x, truth.y, truth.yaw),
        ]
    )
    li = 1 if shared else 0
    level = matcher.levels[li]
    n = sxy.shape[1]
    kernel = match_kernels.gauss_newton_starts
    run = kernel if compiled else jit.python_function(kernel)
    many = states.copy()
    terms = np.empty((1 if shared else len(states), TERM_ROWS, n))
    stopped = np.zeros(len(states), dtype=np.bool_)
    args = (level._table, level.field.shape[1], level.geometry, sxy)
    run(*args, many, matcher._steps, matcher._iterations[li], terms, stopped)
    for k, state in enumerate(states):
        one = state.copy()
        one_terms = np.empty((1, TERM_ROWS, n))
        stop = match_kernels.gauss_newton_level(
            *args, one, matcher._steps, matcher._iterations[li], one_terms
        )
        assert one.tolist() == many[k].tolist()
        assert bool(stopped[k]) == stop == (not shared)
        if not shared:
            assert np.array_equal(one_terms[0], terms[k])
