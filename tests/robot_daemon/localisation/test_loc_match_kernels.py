"""The scan matcher's compiled loops (`match_kernels`) give session 12's numpy results bit for
bit, compiled and as plain Python alike, and compile nothing after the warm-up.

The references below are session 12's numpy code that the kernels replaced (`_corners_at`,
`value_xy`, `interpolate_xy`, `tensor_rows`, `normal_information` and `ScanMatcher.match`), as
it was but for ``self``: every comparison is exact (`np.array_equal`, ``==``), on random
points on and off the field, on the synthetic office and on a real log's map.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon import jit
from robot_daemon.localisation import match_kernels
from robot_daemon.localisation.localiser import Localiser
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
from tests.robot_daemon.localisation.carmen_log import LaserRecord, read_laser_records
from tests.robot_daemon.localisation.log_replay import localise_interleaved, log_config, map_of
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"
# The kernels the matcher calls, and those only other kernels call (compiled into them).
ENTRIES = ("bilinear", "gauss_newton_terms", "inlier_terms", "gauss_newton_level")
INNER = ("solve3", "_pairwise_block", "_pairwise_sum") if jit.ENABLED else ("solve3",)
KERNELS = {name: getattr(match_kernels, name) for name in (*ENTRIES, *INNER)}

# -- session 12's numpy code (the reference) --------------------------------------------------


def corners_at_numpy(level: LikelihoodLevel, pxy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Session 12's `LikelihoodLevel._corners_at` (with its `_columns` and `_clip_into`)."""
    inv = 1.0 / level.resolution
    h, w = level.field.shape
    column = (2,) + (1,) * (pxy.ndim - 1)
    origin = np.array((level.origin_x, level.origin_y)).reshape(column)
    high = np.array((w - 1.001, h - 1.001)).reshape(column)
    uv = pxy - origin
    uv *= inv
    uv += PAD - level.lattice_offset
    np.minimum(uv, high, out=uv)
    np.maximum(uv, 0.0, out=uv)
    ji = uv.astype(np.intp)
    frac = uv - ji
    k = ji[1] * w
    k += ji[0]
    rows = level.corners.T.take(k, axis=0)  # the interleaved corner table
    corners = rows.transpose((k.ndim, *range(k.ndim)))
    return frac, corners


def value_xy_numpy(level: LikelihoodLevel, pxy: np.ndarray) -> np.ndarray:
    """Session 12's `LikelihoodLevel.value_xy`."""
    frac, corners = corners_at_numpy(level, pxy)
    low, high = corners[0::2], corners[1::2]
    ab = high - low
    ab *= frac[0]
    ab += low
    m = ab[1] - ab[0]
    m *= frac[1]
    m += ab[0]
    return m


def interpolate_xy_numpy(level: LikelihoodLevel, pxy: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """Session 12's `LikelihoodLevel.interpolate_xy`."""
    inv = 1.0 / level.resolution
    frac, corners = corners_at_numpy(level, pxy)
    fx, fy = frac[0], frac[1]
    low = corners[0::2]
    d = corners[1::2] - low
    ab = fx * d
    ab += low
    a = ab[0]
    ba = ab[1] - a
    m = fy * ba
    m += a
    d0 = d[0]
    dmx = d[1] - d0
    dmx *= fy
    dmx += d0
    np.multiply(dmx, inv, out=grad[0])
    np.multiply(ba, inv, out=grad[1])
    return m


def tensor_rows_numpy(
    level: LikelihoodLevel, pxy: np.ndarray, index: np.ndarray
) -> np.ndarray | None:
    """Session 12's `LikelihoodLevel.tensor_rows`."""
    if level.tensor is None:
        return None
    h, w = level.field.shape
    uv = pxy.take(index, axis=1)
    uv -= np.array((level.origin_x, level.origin_y)).reshape(2, 1)
    uv *= 1.0 / level.resolution
    uv += PAD - level.lattice_offset
    ij = np.rint(uv, out=uv).astype(np.intp)
    np.minimum(ij, np.array([[w - 1], [h - 1]], dtype=np.intp), out=ij)
    np.maximum(ij, 0, out=ij)
    k = ij[1] * w
    k += ij[0]
    rows: np.ndarray = level.tensor.take(k, axis=0).T.astype(np.float64, order="C")
    return rows


def normal_information_numpy(
    m: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    rx: np.ndarray,
    ry: np.ndarray,
    tensor: Callable[[np.ndarray], np.ndarray | None],
) -> tuple[np.ndarray, int]:
    """Session 12's `normal_information` with the tensor looked up at the inliers."""
    g = np.hypot(gx, gy)
    sel = (m > INLIER_M) & (g > 1e-9)
    index = np.flatnonzero(sel)
    n = int(index.size)
    if n == 0:
        return np.zeros((3, 3)), 0
    rows = tensor(index)
    have = np.zeros(0, dtype=bool) if rows is None else ~np.isnan(rows[0])
    if rows is not None and np.count_nonzero(have) == n:
        txx, txy, tyy = rows[0], rows[1], rows[2]
    else:
        inv = 1.0 / g.take(index)
        nx, ny = gx.take(index) * inv, gy.take(index) * inv
        txx, txy, tyy = nx * nx, nx * ny, ny * ny
        if rows is not None:
            txx = np.where(have, rows[0], txx)
            txy = np.where(have, rows[1], txy)
            tyy = np.where(have, rows[2], tyy)
    jx, jy = -ry.take(index), rx.take(index)
    ax = txx * jx + txy * jy
    ay = txy * jx + tyy * jy
    add = np.add.reduce
    a, b, d = float(add(txx)), float(add(txy)), float(add(tyy))
    e, f = float(add(ax)), float(add(ay))
    c = float(add(jx * ax + jy * ay))
    return np.array([[a, b, e], [b, d, f], [e, f, c]]), n


def solve3_numpy(
    a: float, b: float, c: float, d: float, e: float, f: float, g: list[float]
) -> tuple[float, float, float]:
    """Session 12's `scan_matcher._solve3`."""
    g0, g1, g2 = g
    co0 = d * f - e * e
    co1 = c * e - b * f
    co2 = b * e - c * d
    det = a * co0 + b * co1 + c * co2
    if not abs(det) > 1e-300:
        return 0.0, 0.0, 0.0
    x0 = (g0 * co0 + g1 * co1 + g2 * co2) / det
    x1 = (g0 * co1 + g1 * (a * f - c * c) + g2 * (b * c - a * e)) / det
    x2 = (g0 * co2 + g1 * (b * c - a * e) + g2 * (a * d - b * b)) / det
    return x0, x1, x2


def match_numpy(
    matcher: ScanMatcher, points: np.ndarray, initial: Pose2D, start_level: int | None = None
) -> MatchResult:
    """Session 12's `ScanMatcher.match`."""
    cfg = matcher.config
    fine = subsample_points(points, cfg.max_points)
    px, py, yaw = initial.x, initial.y, initial.yaw
    hessian, normal_info, n_inliers, score = np.zeros((3, 3)), np.zeros((3, 3)), 0, 0.0
    n_levels = len(matcher.levels)
    first = n_levels - 1 if start_level is None else min(max(start_level, 0), n_levels - 1)
    for li in range(first, -1, -1):
        level = matcher.levels[li]
        pts = fine if li == 0 else subsample_points(fine, max(cfg.max_points >> li, 30))
        sx = np.ascontiguousarray(pts[:, 0])
        sy = np.ascontiguousarray(pts[:, 1])
        mxy = np.empty((2, sx.size))
        jac = np.empty((3, sx.size))
        gx, gy, jt = jac
        n_iter = cfg.iterations[n_levels - 1 - li]
        n_max = max(n_iter, cfg.fine_max_iterations) if li == 0 else n_iter
        converged = False
        for it in range(n_max + (1 if li == 0 else 0)):
            c, s = math.cos(yaw), math.sin(yaw)
            rx = c * sx - s * sy
            ry = s * sx + c * sy
            np.add(rx, px, out=mxy[0])
            np.add(ry, py, out=mxy[1])
            m = interpolate_xy_numpy(level, mxy, jac[:2])
            np.subtract(gy * rx, gx * ry, out=jt)
            if li == 0 and (it == n_max or (it >= n_iter and converged)):
                hessian = jac @ jac.T
                score = float(np.add.reduce(m)) / m.size if m.size else 0.0
                normal_info, n_inliers = normal_information_numpy(
                    m, gx, gy, rx, ry, functools.partial(tensor_rows_numpy, level, mxy)
                )
                break
            r = 1.0 - m
            (h00, h01, h02), (_, h11, h12), (_, _, h22) = (jac @ jac.T).tolist()
            g = np.add.reduce(jac * r, axis=1).tolist()
            lam = cfg.damping * (h00 + h11 + h22) / 3.0 + 1e-9
            dx, dy, dth = solve3_numpy(h00 + lam, h01, h02, h11 + lam, h12, h22 + lam, g)
            dth = max(-cfg.max_angular_step, min(cfg.max_angular_step, dth))
            converged = abs(dx) + abs(dy) < cfg.converged_m and abs(dth) < cfg.converged_rad
            px += dx
            py += dy
            yaw += dth
    return MatchResult(
        Pose2D(px, py, yaw), hessian, score, int(fine.shape[0]), normal_info, n_inliers
    )


# -- helpers ----------------------------------------------------------------------------------


def same_match(a: MatchResult, b: MatchResult) -> bool:
    """Two match results equal bit for bit (pose, H, score, counts, information)."""
    return (
        (a.pose.x, a.pose.y, a.pose.yaw) == (b.pose.x, b.pose.y, b.pose.yaw)
        and np.array_equal(a.hessian, b.hessian)
        and a.score == b.score
        and (a.n_points, a.n_inliers) == (b.n_points, b.n_inliers)
        and np.array_equal(a.normal_info, b.normal_info)
    )


def field_points(
    level: LikelihoodLevel, rng: np.random.Generator, shape: tuple[int, ...]
) -> np.ndarray:
    """Points (2, *shape) over the level's field and a margin beyond it, some exactly on
    lattice nodes, some far off (clipped to the border)."""
    h, w = level.field.shape
    res, off = level.resolution, PAD - level.lattice_offset
    x0, y0 = level.origin_x - off * res, level.origin_y - off * res  # node (0, 0)
    pxy = np.stack(
        (
            rng.uniform(x0 - 1.0, x0 + w * res + 1.0, shape),
            rng.uniform(y0 - 1.0, y0 + h * res + 1.0, shape),
        )
    )
    flat = pxy.reshape(2, -1)
    k = flat.shape[1]
    nodes = rng.integers(0, (w, h), (k // 10, 2)).T  # (column, row) of lattice nodes
    flat[0, : k // 10] = level.origin_x + (nodes[0] - off) * res
    flat[1, : k // 10] = level.origin_y + (nodes[1] - off) * res
    far = np.array(((-1e6, 1e6, 0.0, 3e5), (1e6, -1e6, -3e5, 0.0)))
    flat[:, k // 10 : k // 10 + 4] = far[:, : min(4, k - k // 10)]
    return pxy


def intel_records(n: int) -> list[LaserRecord]:
    path = LOGS / "intel-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    return read_laser_records(path)[:n]


def office_matcher(surface: str, obstacles: bool) -> ScanMatcher:
    matcher = ScanMatcher(office_grid(), ScanMatcherConfig(surface=surface))
    if obstacles:
        rng = np.random.default_rng(21)
        matcher.add_obstacles(rng.uniform(0.0, 20.0, 40), rng.uniform(0.0, 10.0, 40))
    return matcher


def _check_bilinear(level: LikelihoodLevel, pxy: np.ndarray) -> None:
    grad_ref = np.empty_like(pxy)
    m_ref = interpolate_xy_numpy(level, pxy, grad_ref)
    grad = np.empty_like(pxy)
    assert np.array_equal(level.interpolate_xy(pxy, grad), m_ref)
    assert np.array_equal(grad, grad_ref)
    assert np.array_equal(level.value_xy(pxy), value_xy_numpy(level, pxy))
    assert np.array_equal(level.value_xy(pxy), m_ref)


# -- the tests --------------------------------------------------------------------------------


@pytest.mark.parametrize("obstacles", [False, True])
@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_bilinear_values_and_gradients_equal_session_12s(surface: str, obstacles: bool) -> None:
    """`LikelihoodLevel.interpolate_xy` and `value_xy` (`match_kernels.bilinear`) give the
    numpy code's M and ∇M bit for bit on every level, for points on and off the field, on
    lattice nodes, and stacked as one scan, as starts and as the slide profile has them."""
    rng = np.random.default_rng(31)
    for level in office_matcher(surface, obstacles).levels:
        for shape in ((3000,), (7, 400), (3, 13, 50)):
            _check_bilinear(level, field_points(level, rng, shape))


@pytest.mark.realdata
def test_bilinear_values_and_gradients_equal_session_12s_on_a_real_map() -> None:
    """The same on the Intel lab's map (cell centres), at and around its scans' end points."""
    records = intel_records(300)
    loc = Localiser(map_of(records[::2]), log_config())
    rng = np.random.default_rng(32)
    for level in loc.matcher.levels:
        _check_bilinear(level, field_points(level, rng, (20000,)))
        for record in records[1::20]:
            pts = loc._scan_points(record.scan)
            c, s = math.cos(record.pose.yaw), math.sin(record.pose.yaw)
            shift = rng.normal(0.0, 0.05, (2, 1))
            pxy = np.stack(
                (
                    c * pts[:, 0] - s * pts[:, 1] + record.pose.x,
                    s * pts[:, 0] + c * pts[:, 1] + record.pose.y,
                )
            )
            _check_bilinear(level, pxy + shift)


def test_a_nan_point_reads_the_padding() -> None:
    """A NaN end point reads M = 0 and ∇M = 0 (the padding) instead of memory off the table."""
    level = office_matcher("cell_face", False).levels[0]
    pxy = np.array([[np.nan, 1.0, np.nan], [1.0, np.nan, np.nan]])
    grad = np.empty_like(pxy)
    assert np.array_equal(level.interpolate_xy(pxy, grad), np.zeros(3))
    assert np.array_equal(grad, np.zeros((2, 3)))


def _starts(prior: Pose2D, rng: np.random.Generator, n: int) -> list[Pose2D]:
    """``n`` starts around ``prior`` (0.15 m, 10 degrees) and two off the map."""
    starts = [
        Pose2D(
            prior.x + rng.normal(0.0, 0.15),
            prior.y + rng.normal(0.0, 0.15),
            prior.yaw + rng.normal(0.0, math.radians(10.0)),
        )
        for _ in range(n)
    ]
    return [*starts, Pose2D(-50.0, 3.0, 0.2), Pose2D(prior.x, 500.0, -3.0)]


@pytest.mark.parametrize("obstacles", [False, True])
@pytest.mark.parametrize("surface", ["cell_face", "cell_centre"])
def test_match_equals_session_12s_numpy_match(surface: str, obstacles: bool) -> None:
    """`ScanMatcher.match` (one kernel call per Gauss-Newton iteration) and `match_many` (the
    starts stacked) give session 12's numpy `match` bit for bit: pose, H, score, information,
    from every start level, from good and poor starts and off the map."""
    rng = np.random.default_rng(33)
    matcher = office_matcher(surface, obstacles)
    loc = Localiser(office_grid())
    for _ in range(4):
        truth = Pose2D(rng.uniform(0.5, 19.5), rng.uniform(0.5, 9.5), rng.uniform(-4.0, 4.0))
        points = loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng))
        starts = _starts(truth, rng, 6)
        for start_level in (None, 2, 1, 0):
            want = [match_numpy(matcher, points, p, start_level) for p in starts]
            for p, expected in zip(starts, want, strict=True):
                assert same_match(matcher.match(points, p, start_level), expected)
            for got, expected in zip(
                matcher.match_many(points, starts, start_level), want, strict=True
            ):
                assert same_match(got, expected)


@pytest.mark.realdata
def test_match_equals_session_12s_numpy_match_on_a_real_log() -> None:
    """The same on the Intel lab's log (a cell-centre map of its first 400 scans, every second
    one): 100 scans each from its logged pose and from random starts around it."""
    records = intel_records(400)
    loc = Localiser(map_of(records[::2]), log_config())
    rng = np.random.default_rng(34)
    for record in records[1::4]:
        points = loc._scan_points(record.scan)
        starts = [record.pose, *_starts(record.pose, rng, 2)]
        for start_level in (None, 1):
            want = [match_numpy(loc.matcher, points, p, start_level) for p in starts]
            for p, expected in zip(starts, want, strict=True):
                assert same_match(loc.matcher.match(points, p, start_level), expected)
            many = loc.matcher.match_many(points, starts, start_level)
            assert all(same_match(a, b) for a, b in zip(many, want, strict=True))


def test_normal_information_equals_session_12s() -> None:
    """`normal_information` (`match_kernels.inlier_terms` and numpy's sums) gives session 12's
    bit for bit, with a tensor at every inlier, at some, and none, on random M and ∇M."""
    rng = np.random.default_rng(35)
    level = office_matcher("cell_face", True).levels[0]
    full = level.tensor
    assert full is not None
    holed = full.copy()
    holed[rng.random(holed.shape[0]) < 0.3] = np.nan
    for n in (0, 1, 7, 130, 400, 1081):
        pxy = field_points(level, rng, (n,))
        m = rng.uniform(0.0, 1.0, n)
        m[rng.random(n) < 0.2] = INLIER_M  # on the threshold: an outlier
        grad = rng.normal(0.0, 3.0, (2, n))
        grad[:, rng.random(n) < 0.1] = 0.0  # no direction: an outlier
        rxy = rng.normal(0.0, 5.0, (2, n))
        for tensor in (full, holed, None):
            level.tensor = tensor
            want = normal_information_numpy(
                m,
                grad[0],
                grad[1],
                rxy[0],
                rxy[1],
                functools.partial(tensor_rows_numpy, level, pxy),
            )
            got = normal_information(m, grad[0], grad[1], rxy[0], rxy[1], pxy, level)
            assert got[1] == want[1]
            assert np.array_equal(got[0], want[0])
    level.tensor = full


def test_compiled_kernels_equal_their_python_functions() -> None:
    """Each kernel compiled and as plain Python (`jit.python_function`) writes the same bits."""
    rng = np.random.default_rng(36)
    matcher = office_matcher("cell_face", True)
    level = matcher.levels[0]
    table, w, geometry = level.corners.T, level.field.shape[1], level.geometry
    assert table.flags.c_contiguous
    pxy = np.ascontiguousarray(field_points(level, rng, (500,)))
    outs = []
    for kernel in (match_kernels.bilinear, jit.python_function(match_kernels.bilinear)):
        m, grad = np.empty(500), np.empty((2, 500))
        kernel(table, w, geometry, pxy, m, grad)
        outs.append((m, grad))
    assert all(np.array_equal(a, b) for a, b in zip(*outs, strict=True))

    loc = Localiser(office_grid())
    truth = Pose2D(5.0, 4.0, 0.3)
    pts = subsample_points(loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng)), 400)
    sxy = np.ascontiguousarray(pts.T)
    yaws = truth.yaw + rng.normal(0.0, 0.2, 3)
    poses = np.stack(
        (
            truth.x + rng.normal(0.0, 0.2, 3),
            truth.y + rng.normal(0.0, 0.2, 3),
            np.cos(yaws),
            np.sin(yaws),
        )
    ).T.copy()
    n = sxy.shape[1]
    terms = []
    for kernel in (
        match_kernels.gauss_newton_terms,
        jit.python_function(match_kernels.gauss_newton_terms),
    ):
        out = np.empty((3, match_kernels.TERM_ROWS, n))
        kernel(table, w, geometry, sxy, poses, out)
        terms.append(out)
    assert np.array_equal(terms[0], terms[1])

    t = terms[0][1]  # M, J, J r, R(ψ) s, S of the second start
    assert level.tensor is not None
    h = level.field.shape[0]
    counts = []
    for kernel in (match_kernels.inlier_terms, jit.python_function(match_kernels.inlier_terms)):
        out = np.zeros((6, n))
        k = kernel(
            t[0], t[1], t[2], t[7], t[8], t[9:11], level.tensor, w, h, geometry, INLIER_M, out
        )
        counts.append((k, out))
    assert counts[0][0] == counts[1][0] > 0
    assert np.array_equal(counts[0][1], counts[1][1])


def _signatures() -> dict[str, int]:
    return {name: len(getattr(k, "signatures", ())) for name, k in KERNELS.items()}


def test_kernels_are_compiled_with_numba_or_plain_python_without() -> None:
    """With numba the kernels the matcher calls are compiled (a signature each after
    `jit.warm_up`); with ``INTERBOT_NO_JIT`` they are the plain functions."""
    jit.warm_up()
    if jit.ENABLED:
        assert all(_signatures()[name] >= 1 for name in ENTRIES)
    else:
        assert all(jit.python_function(k) is k for k in KERNELS.values())


def test_a_run_after_warm_up_compiles_nothing() -> None:
    """After `jit.warm_up` (as the daemon and the scenario runner call it) 200 scans of the
    synthetic office, with a pose set every 25 (the 25-start first match), add no signature
    to any kernel: nothing compiles in the control loop."""
    jit.warm_up()
    before = _signatures()
    rng = np.random.default_rng(37)
    loc = Localiser(office_grid())
    truth = Pose2D(3.0, 2.5, 0.0)
    for k in range(200):
        truth = Pose2D(3.0 + 0.05 * k, 2.5 + 0.5 * math.sin(0.05 * k), 0.1 * math.sin(0.03 * k))
        loc.on_odometry(truth, 0.1 * k)
        if k % 25 == 0:
            loc.set_initial_pose(Pose2D(truth.x + 0.1, truth.y - 0.1, truth.yaw + 0.1), 0.1 * k)
        loc.on_scan(utm_scan(OFFICE_BOXES, truth, 0.1 * k, rng), 0.1 * k + 0.05)
    assert _signatures() == before


@pytest.mark.realdata
def test_a_real_log_replay_after_warm_up_compiles_nothing() -> None:
    """The same over 300 scans of the Intel lab's log (the bench's replay)."""
    records = intel_records(600)
    jit.warm_up()
    before = _signatures()
    stats = localise_interleaved(LOGS / "intel-corrected.log.gz", 2, records=records)
    assert stats["scans"] >= 250
    assert _signatures() == before


# -- numpy's sums in compiled code (`match_kernels.row_sums_into`, `gram_into`) ----------------


def _compiled(function: Callable[..., None]) -> Callable[..., None]:
    """``function`` compiled when kernels are, without numba's cache (a cached test function
    would not see a change of `match_kernels`: the cache checks its own file only)."""
    if not jit.ENABLED:
        return function
    import numba

    compiled: Callable[..., None] = numba.njit(error_model="numpy")(function)
    return compiled


@_compiled
def _row_sums(a: np.ndarray, out: np.ndarray) -> None:
    match_kernels.row_sums_into(a, out)


@_compiled
def _gram(a: np.ndarray, out: np.ndarray) -> None:
    match_kernels.gram_into(a, out)


def _awkward(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Values over 16 orders of magnitude, of both signs, some -0.0 and some 0.0."""
    a = rng.normal(0.0, 1.0, shape) * 10.0 ** rng.uniform(-8.0, 8.0, shape)
    a[rng.random(shape) < 0.05] = -0.0
    a[rng.random(shape) < 0.05] = 0.0
    return a


def test_compiled_row_sums_are_numpys_pairwise_sums() -> None:
    """Compiled `row_sums_into` (numpy's pairwise summation rewritten) gives
    ``np.add.reduce(a, axis=1)`` bit for bit, the sign of a zero too, for rows of every length
    up to beyond three halvings (0..1100, and 5000: ``max_points``' top), of a (3, n) array
    and of the J r rows of a stack of terms (plain Python: numpy itself)."""
    rng = np.random.default_rng(38)
    lengths = [*range(0, 300), *rng.integers(300, 1100, 200).tolist(), 5000]
    for n in lengths:
        terms = _awkward(rng, (2, match_kernels.TERM_ROWS, n))
        stacked = np.add.reduce(terms[:, 4:7], axis=2)[1]
        for a in (terms[1, 4:7], np.ascontiguousarray(terms[1, 4:7])):
            out = np.empty(3)
            _row_sums(a, out)
            want = np.add.reduce(a, axis=1)
            assert np.array_equal(out, want)
            assert np.array_equal(np.signbit(out), np.signbit(want))
            assert np.array_equal(out, stacked)


def test_compiled_gram_is_numpys_product() -> None:
    """Compiled `gram_into` (numpy's BLAS ``syrk``, or numpy through a callback) gives
    ``a @ a.T`` bit for bit, the empty product too; so does the callback called directly."""
    rng = np.random.default_rng(39)
    for n in [*range(0, 200), *rng.integers(200, 3000, 100).tolist()]:
        terms = _awkward(rng, (1, match_kernels.TERM_ROWS, n))
        jac = terms[0, 1:4]
        out = np.full((3, 3), np.nan)
        _gram(jac, out)
        assert np.array_equal(out, jac @ jac.T)
        if n > 0:
            c = np.full((3, 3), np.nan)
            args = (3, n, 1.0, jac.ctypes.data, n, 0.0, c.ctypes.data, 3)
            match_kernels._syrk_by_numpy(101, 121, 111, *args)
            assert np.array_equal(c, jac @ jac.T)


def test_compiled_gauss_newton_level_equals_its_python_function() -> None:
    """One level's iterations compiled and as plain Python (numpy's sums): the same state and
    terms, on every level of the office, coarse (no final evaluation) and finest."""
    rng = np.random.default_rng(40)
    matcher = office_matcher("cell_face", True)
    loc = Localiser(office_grid())
    truth = Pose2D(6.0, 3.0, -0.4)
    fine = subsample_points(loc._scan_points(utm_scan(OFFICE_BOXES, truth, 0.0, rng)), 400)
    plain = jit.python_function(match_kernels.gauss_newton_level)
    start = (truth.x + 0.1, truth.y - 0.08, truth.yaw + 0.07)
    for li, level in enumerate(matcher.levels):
        pts = fine if li == 0 else subsample_points(fine, max(400 >> li, 30))
        sxy = np.ascontiguousarray(pts.T)
        runs = []
        for kernel in (match_kernels.gauss_newton_level, plain):
            state = np.array(start)
            terms = np.empty((1, match_kernels.TERM_ROWS, sxy.shape[1]))
            table, w = level.corners.T, level.field.shape[1]
            steps, iterations = matcher._steps, matcher._iterations[li]
            stopped = kernel(table, w, level.geometry, sxy, state, steps, iterations, terms)
            runs.append((stopped, state, terms))
        (s0, x0, t0), (s1, x1, t1) = runs
        assert s0 == s1 == (li == 0)
        assert np.array_equal(x0, x1)
        assert np.array_equal(t0, t1)
        assert not np.array_equal(x0, start)
