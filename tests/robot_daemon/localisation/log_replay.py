"""Localisation replayed on real laser logs (Radish / Freiburg CARMEN logs), for tests and benches.

The logged poses are GMapping-corrected SLAM estimates (a few centimetres), not ground truth;
errors are against them. Two methods, both as ``../shared/data/README.md`` suggests:

* **Revisits** (`localise_revisits`). A map is built with `grid_from_scans` from the first part
  of a log and its logged poses. The scans of the later part that revisit the mapped area
  (logged pose within 1 m of a mapping pose) are localised in runs; two runs are one where the
  path between them stays within 2 m of one (`revisit_runs`). Only logs that come back to
  where they have been can be evaluated this way (not ACES or CSAIL).
* **Interleaved, whole log** (`localise_interleaved`). Every ``k``-th scan builds the map; the
  scans half-way between them are localised *forward through the whole log in one run*, from
  the first pose. The localised scans are not in the map, but scans taken a stride earlier and
  later are: easier than a revisit, but it covers every corridor and hall of every log.

In both, the localiser is started at the logged pose with the default initial covariance (a
person's 0.3 m / 10 degrees), is given the logged pose again after each scan it reports
``lost`` (the user's "Help me!"; ``lost_scans`` counts them), and gets odometry made from the logged pose increments with 5 %
scale error, a yaw bias of 0.02 rad per metre and Gaussian noise (1 cm, 0.005 rad per step).

Each localised scan is scored (`ScanOutcome`): position and heading error, the reported state,
and the error's Mahalanobis distance under the reported covariance (NEES), and how much of what
it sees the map holds (`view_mapped`: a revisit's scan that looks where the first pass never
mapped measures dead reckoning, not a revisit; ``seen_*`` figures leave such scans out). A *silent failure*
is a scan with error > 0.3 m or > 10 degrees reported ``ok`` (issue 12): the figure that must
be 0. `summarise` turns the outcomes into the figures of the tests and of
``bench/bench_reallogs.py``.
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.spatial import cKDTree

from interbot_core.geometry import Pose2D, wrap_angle
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from robot_daemon.config import LocaliserSettings
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.scan_matcher import subsample_points
from robot_daemon.localisation.wall_model import wall_model_setting

REVISIT_RADIUS_M = 1.0  # [m] a scan revisits the map when its pose is this close to a mapping pose
BRIDGE_RADIUS_M = 2.0  # [m] two revisit runs are one if the path between stays this close
if TYPE_CHECKING:  # the records come from the caller (tests and bench/bench_reallogs.py)
    from tests.robot_daemon.localisation.carmen_log import LaserRecord

SILENT_ERROR_M = 0.3  # [m] an error above this (or SILENT_ERROR_RAD) reported ok is silent
# A scan's view is mapped when at least this fraction of its end points, at its logged pose,
# fall where the map has observed (`view_mapped`): the localiser's own bar for a scan that fits
# the map (`LocaliserConfig.lost_confidence`). Below it, not even the logged pose can make the
# scan fit: its error measures dead reckoning through an unmapped view (the ``seen_*`` figures
# leave it out; every other figure keeps it).
VIEW_MAPPED_MIN = LocaliserConfig().lost_confidence
SILENT_ERROR_RAD = math.radians(10.0)
MAP_RESOLUTION = 0.05  # [m]
# The wall model replayed: the daemon's default (``learn``: the robot finds out; on a map binned
# from scan end points it should settle on ``cell_centre``), or a fixed one
# (``bench/bench_reallogs.py --surface cell_centre``).
REPLAY_SURFACE = LocaliserSettings().map_surface


class LogReplayError(ValueError):
    """A log cannot be replayed as asked (the message names the log and what is missing)."""


@dataclass(frozen=True)
class ScanOutcome:
    """One localised scan against the logged pose."""

    error_m: float
    yaw_error_rad: float
    state: LocaliserState
    nees: float  # eᵀ P⁻¹ e with e = (dx, dy, dyaw) (3 dof: mean 3 if P is calibrated)
    seconds: float  # time in Localiser.on_scan by the injected clock (0 without one)
    odometry_error_m: float  # dead reckoning alone from the run's start
    # How the logged pose itself sits in the map (`reference_check`): the distance [m] from it
    # to the scan's own best fit in the map near it (the heading difference is the last
    # field), and whether the estimate fits the scan to the map at least as well as the logged
    # pose does.
    reference_offset_m: float = math.nan
    estimate_fits_better: bool = False
    # The first scan after the logged pose was given again (a re-set after a loss): the
    # localiser's first match then runs from 25 starts (`Localiser._match_from_starts`).
    after_set_pose: bool = False
    # The wall model the matcher used for this scan (`Localiser.wall_model`) and whether it was
    # learnt by then.
    wall_model: str = ""
    wall_model_learnt: bool = False
    # The heading part of the reference offset above [rad] (`reference_check`).
    reference_heading_offset_rad: float = math.nan
    # The pose on the map (`Localiser.pose`, navigation's) against the logged pose, and its NEES
    # under its own covariance: the same as ``error_m`` and ``nees`` where the reported pose is
    # the map pose (the building-pose filter `map_offset` off, not started, or lost).
    map_error_m: float = math.nan
    map_nees: float = math.nan
    # CPU time [s] in Localiser.on_scan by the injected ``cpu_clock`` (this thread's: no other
    # process's time slices, which the wall clock holds on a shared machine; 0 without one).
    cpu_seconds: float = 0.0
    # Why the state is degraded or lost (`LocaliserEstimate.reason`; "" when ok).
    reason: str = ""
    # The fraction of the scan's end points that fall, at the logged pose, where the map has
    # observed (`view_mapped`; nan: not computed).
    view_mapped: float = math.nan

    @property
    def seen(self) -> bool:
        """Whether the map holds enough of what the scan sees to judge it (`VIEW_MAPPED_MIN`);
        True where `view_mapped` was not computed."""
        return not self.view_mapped < VIEW_MAPPED_MIN

    @property
    def silent(self) -> bool:
        """Wrong (> 0.3 m or > 10 degrees) while reported ok."""
        wrong = self.error_m > SILENT_ERROR_M or self.yaw_error_rad > SILENT_ERROR_RAD
        return wrong and self.state is LocaliserState.OK


def log_config(map_surface: str | None = None) -> LocaliserConfig:
    """The localiser's configuration for maps built from logged scans (`grid_from_scans`): the
    wall model of ``map_surface`` (default `REPLAY_SURFACE`; a wall lies anywhere in its binned
    cell, on average mid-cell, which ``learn`` must find out); and every surface the mapping
    scans saw is an occupied cell, so the edge between free and unknown space is where those
    scans ran out of range or out of view, never a wall (``unknown_edges_are_surfaces`` is for
    map_server maps whose walls are grey edges; here it made the Freiburg campus whole-log RMS
    8.3 m instead of 14 cm, reported degraded/lost)."""
    matcher, wall_model = wall_model_setting(map_surface or REPLAY_SURFACE)
    return LocaliserConfig(matcher=matcher, wall_model=wall_model, unknown_edges_are_surfaces=False)


def map_of(records: Sequence[LaserRecord]) -> OccupancyGrid:
    """The 0.05 m map of ``records`` at their logged poses."""
    if not records:
        raise LogReplayError("no scans to build a map from")
    return grid_from_scans([r.scan for r in records], [r.pose for r in records], MAP_RESOLUTION)


def map_fit(loc: Localiser, points: np.ndarray, pose: Pose2D) -> float:
    """Mean likelihood ``M`` of the end points at ``pose`` on the matcher's finest level (its
    score: 1 when every end point lies on a mapped surface)."""
    level = loc.matcher.levels[0]
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    xs = pose.x + c * points[:, 0] - s * points[:, 1]
    ys = pose.y + s * points[:, 0] + c * points[:, 1]
    return float(np.mean(level.value(xs, ys))) if points.size else 0.0


def observed_cells(grid: OccupancyGrid, tolerance_m: float) -> npt.NDArray[np.bool_]:
    """The cells of ``grid`` where the map has observed something: every known cell (free or
    occupied: the mapping scans' beams passed or ended there) and every cell whose centre lies
    within ``tolerance_m`` of an occupied one's (the localiser's hit, `LocaliserConfig.
    hit_tolerance_m`, reaches that far into unknown space). (height, width), row-major."""
    occupied = grid.cells == OCCUPIED
    r = int(tolerance_m / grid.resolution + 1e-9)
    k = np.arange(-r, r + 1)
    disk = k[None, :] ** 2 + k[:, None] ** 2 <= r * r
    near: npt.NDArray[np.bool_] = ndimage.binary_dilation(occupied, structure=disk)
    return near | (grid.cells != UNKNOWN)


def view_mapped(
    observed: npt.NDArray[np.bool_], grid: OccupancyGrid, points: np.ndarray, pose: Pose2D
) -> float:
    """The fraction of sensor-frame end points ``points`` (N, 2) [m] that fall, at ``pose``,
    on cells ``observed`` (`observed_cells` of ``grid``): how much of what the scan sees the
    map holds at all, right or wrong. The hit fraction (`Localiser`'s confidence) at any pose
    whose end points land where these do cannot exceed it; end points off the map count as
    unobserved; 0 without end points.

    The revisit method selects scans by position (within `REVISIT_RADIUS_M` of a mapping
    pose), not by view: a second pass that drives the first one's path the other way, with a
    180-degree laser, looks where the first pass never looked (the Freiburg campus, log
    1335-1367: headings 174 degrees from the nearest mapping pose, 81 % of the end points on
    unknown cells, 79 % beyond the map's 15 m)."""
    if points.shape[0] == 0:
        return 0.0
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    xs = pose.x + c * points[:, 0] - s * points[:, 1]
    ys = pose.y + s * points[:, 0] + c * points[:, 1]
    row, col = grid.world_to_cell(xs, ys)
    inside = grid.in_bounds(row, col)
    seen = np.zeros(points.shape[0], dtype=bool)
    seen[inside] = observed[row[inside], col[inside]]
    return float(np.count_nonzero(seen)) / points.shape[0]


def scan_view_mapped(
    observed: npt.NDArray[np.bool_],
    grid: OccupancyGrid,
    config: LocaliserConfig,
    record: LaserRecord,
) -> float:
    """`view_mapped` of ``record``'s scan at its logged pose, with the end points the localiser
    of ``config`` matches (within ``max_range_m``, at most the matcher's ``max_points``)."""
    points = subsample_points(record.scan.points(config.max_range_m), config.matcher.max_points)
    return view_mapped(observed, grid, points, record.pose)


def reference_fit(loc: Localiser, record: LaserRecord) -> tuple[Pose2D, np.ndarray] | None:
    """The map's own best fit of ``record``'s scan near its logged pose (`reference_check`)
    and the matched end points; None when the scan has fewer than 10 of them."""
    points = subsample_points(
        record.scan.points(loc.config.max_range_m), loc.matcher.config.max_points
    )
    if points.shape[0] < 10:
        return None
    return loc.matcher.match(points, record.pose).pose, points


def reference_check(
    loc: Localiser, record: LaserRecord, estimate: Pose2D
) -> tuple[float, float, bool]:
    """How far the logged pose is from the map's own best fit of its scan (distance [m],
    heading [rad]), and whether the estimate explains the scan at least as well as the logged
    pose.

    The logged poses are a SLAM estimate, and the revisit method's map comes from an earlier
    pass whose poses have errors of their own: where the two disagree, no localiser can be
    nearer the logged pose than that. The scan is matched (every level, coarse to fine: a basin
    of a few decimetres) from the logged pose: the distance to that optimum is the *reference
    offset* of the scan. Scans
    along a featureless corridor have no sharp optimum, so the offset there also holds the
    matcher's slack; the offsets' RMS is an indication of the floor, not a correction. Neither
    figure feeds the localiser or changes the error figures.
    """
    fit = reference_fit(loc, record)
    if fit is None:
        return math.nan, math.nan, False
    optimum, points = fit
    better = map_fit(loc, points, estimate) >= map_fit(loc, points, record.pose)
    turn = abs(wrap_angle(optimum.yaw - record.pose.yaw))
    return optimum.distance_to(record.pose), turn, better


# ------------------------------------------------------------------ the reference's own noise
# How well do the logged poses agree with their own scans, without the map and without the
# localiser's matcher? Each scan is matched to the two scans logged just before it, at their
# logged poses, by point-to-line ICP (Censi, "An ICP variant using a point-to-line metric",
# ICRA 2008): end points against the segments between neighbouring end points, so neither the
# map's 5 cm cells nor the likelihood field enters. With exact poses the match lands on the
# logged pose (the synthetic office with a 180-degree, 1 cm-noise laser: 0.3 cm, 0.06 degrees,
# `test_loc_reference_consistency.py`); how far it lands from it on a log is how much the
# logged poses of neighbouring scans disagree with what those scans see: noise that the map
# (built from the same poses) is blurred by and that the replay's odometry (made from the logged
# increments) carries too.

CONSISTENCY_GAP_M = 0.5  # [m] a scan is checked only when both scans before it are this close
CONSISTENCY_RANGE_M = 10.0  # [m] beams beyond are left out (sparse far walls, long baselines)
CONSISTENCY_PAIR_M = 0.1  # [m] an end point farther than this from the other scans is an outlier


def point_to_line_icp(
    reference: npt.NDArray[np.float64],
    points: npt.NDArray[np.float64],
    start: Pose2D,
    iterations: int = 30,
) -> Pose2D | None:
    """The pose that puts sensor-frame ``points`` (N, 2) [m] on the map-frame ``reference``
    points' local lines, from ``start`` (Gauss-Newton on the point-to-line distances: for each
    transformed point, its two nearest reference points within `CONSISTENCY_PAIR_M` give the
    line; the residual is the distance along that line's normal ``n``, its Jacobian
    ``(n_x, n_y, n · ∂S/∂ψ)``). None when fewer than 20 points pair up."""
    tree = cKDTree(reference)
    x, y, yaw = start.x, start.y, start.yaw
    for _ in range(iterations):
        c, s = math.cos(yaw), math.sin(yaw)
        rx = c * points[:, 0] - s * points[:, 1]
        ry = s * points[:, 0] + c * points[:, 1]
        moved = np.column_stack((rx + x, ry + y))
        dist, idx = tree.query(moved, k=2)
        paired = dist[:, 1] < CONSISTENCY_PAIR_M
        a, b = reference[idx[paired, 0]], reference[idx[paired, 1]]
        along = b - a
        length = np.hypot(along[:, 0], along[:, 1])
        line = length > 1e-6
        if np.count_nonzero(line) < 20:
            return None
        n = np.column_stack((-along[line, 1], along[line, 0])) / length[line, None]
        r = np.sum((moved[paired][line] - a[line]) * n, axis=1)
        jac = np.column_stack(
            (n[:, 0], n[:, 1], -n[:, 0] * ry[paired][line] + n[:, 1] * rx[paired][line])
        )
        step = -np.linalg.solve(jac.T @ jac + 1e-9 * np.eye(3), jac.T @ r)
        x, y, yaw = x + float(step[0]), y + float(step[1]), yaw + float(step[2])
        if abs(step[0]) + abs(step[1]) < 1e-5 and abs(step[2]) < 1e-6:
            break
    return Pose2D(x, y, yaw)


def reference_consistency(records: Sequence[LaserRecord], samples: int = 300) -> dict[str, float]:
    """How far each logged pose lies from where its scan fits the two scans logged before it
    (`point_to_line_icp` from the logged pose; about ``samples`` scans at a fixed stride, those
    whose two predecessors are within `CONSISTENCY_GAP_M`): ``consistency_rms_m`` and
    ``consistency_rms_rad`` (RMS position and heading) and ``consistency_scans`` (how many);
    nan where no scan qualifies (logs with a scan every metre rarely have one)."""
    pairs = []
    for i in range(2, len(records), max(1, len(records) // samples)):
        before = records[i - 2 : i]
        if all(records[i].pose.distance_to(r.pose) <= CONSISTENCY_GAP_M for r in before):
            pairs.append((records[i], before))
    return _consistency(pairs)


def reference_pass_consistency(
    records: Sequence[LaserRecord], split: int, samples: int = 300
) -> dict[str, float]:
    """`reference_consistency` between passes, the revisit method's floor: each scan after
    ``split`` (about ``samples`` of them) fitted to the two scans before ``split`` nearest its
    logged pose, where both lie within `CONSISTENCY_GAP_M` and face within 45 degrees of it
    (they see the same walls). The revisit's map is built from those scans at those poses: where
    the two passes' logged poses disagree, no localiser can be nearer the later ones."""
    earlier = records[:split]
    if not earlier:
        return _consistency([])
    xyt = np.array([(r.pose.x, r.pose.y, r.pose.yaw) for r in earlier])
    pairs = []
    for i in range(split, len(records), max(1, (len(records) - split) // samples)):
        p = records[i].pose
        turn = np.abs(np.remainder(xyt[:, 2] - p.yaw + math.pi, math.tau) - math.pi)
        d = np.where(turn < math.radians(45.0), np.hypot(xyt[:, 0] - p.x, xyt[:, 1] - p.y), np.inf)
        near = np.argsort(d)[:2]
        if near.size == 2 and d[near[-1]] <= CONSISTENCY_GAP_M:
            pairs.append((records[i], [earlier[k] for k in near]))
    return _consistency(pairs)


def _consistency(pairs: Sequence[tuple[LaserRecord, Sequence[LaserRecord]]]) -> dict[str, float]:
    """Each scan of ``pairs`` fitted from its logged pose to its reference scans at theirs
    (`point_to_line_icp`): the RMS offsets from the logged poses and their number."""
    offsets = []
    for cur, others in pairs:
        reference = np.vstack(
            [scan_points_in_map(r.scan, r.pose, CONSISTENCY_RANGE_M) for r in others]
        )
        fit = point_to_line_icp(reference, cur.scan.points(CONSISTENCY_RANGE_M), cur.pose)
        if fit is not None:
            offsets.append((fit.distance_to(cur.pose), wrap_angle(fit.yaw - cur.pose.yaw)))
    if not offsets:
        return {
            "consistency_rms_m": math.nan,
            "consistency_rms_rad": math.nan,
            "consistency_scans": 0.0,
        }
    o = np.array(offsets)
    return {
        "consistency_rms_m": float(np.sqrt(np.mean(o[:, 0] ** 2))),
        "consistency_rms_rad": float(np.sqrt(np.mean(o[:, 1] ** 2))),
        "consistency_scans": float(len(offsets)),
    }


def replay_run(
    grid: OccupancyGrid,
    run: Sequence[LaserRecord],
    rng: np.random.Generator,
    config: LocaliserConfig | None = None,
    clock: Callable[[], float] | None = None,
    reinit_lost: bool = True,
    check_reference: bool = True,
    prototype: Localiser | None = None,
    cpu_clock: Callable[[], float] | None = None,
    observe: Callable[[Localiser, LaserRecord, ScanOutcome], None] | None = None,
) -> list[ScanOutcome]:
    """Localise ``run`` in ``grid`` from its first logged pose with noisy, drifting odometry.

    ``clock`` (e.g. ``time.perf_counter``, injected by a benchmark) times each `on_scan`;
    ``cpu_clock`` (e.g. ``time.thread_time``) too, in CPU time.
    ``reinit_lost``: after a scan reported ``lost`` the localiser is given the logged pose, as
    the robot's user would give it a new initial pose (each is counted: ``lost_scans`` then
    counts the losses; without it a loss lasts to the end of the run, on odometry alone).
    ``check_reference``: score the logged pose itself (`reference_check`, a match of every scan
    from its logged pose: a third of the replay's time); without it the outcomes' reference
    fields are nan and False, every other figure the same.
    ``prototype``: an unused localiser of ``grid`` and ``config`` to copy instead of building
    one (on a large map the distance fields cost seconds; a copy is the same localiser).
    ``observe``: called after each localised scan with the localiser, the record and its
    outcome, before a lost scan's re-set (`tools/reallog_decompose.py` looks at the map there).
    """
    if len(run) < 2:
        return []
    stamps = replay_stamps(run)
    if prototype is not None:
        loc = copy.deepcopy(prototype)
    else:
        loc = Localiser(grid, config or log_config())
    observed = observed_cells(grid, loc.config.hit_tolerance_m)
    odom = Pose2D(0.0, 0.0, 0.0)
    loc.on_odometry(odom, stamps[0])
    loc.set_initial_pose(run[0].pose, stamps[0])
    loc.on_scan(run[0].scan, stamps[0])
    out: list[ScanOutcome] = []
    after_set_pose = False
    for k, (prev, cur) in enumerate(itertools.pairwise(run), start=1):
        now = stamps[k]
        inc = cur.pose.relative_to(prev.pose)
        dist = math.hypot(inc.x, inc.y)
        noisy = Pose2D(
            1.05 * inc.x + rng.normal(0.0, 0.01),
            1.05 * inc.y + rng.normal(0.0, 0.01),
            inc.yaw + 0.02 * dist + rng.normal(0.0, 0.005),
        )
        odom = odom.compose(noisy)
        loc.on_odometry(odom, now)
        c0 = cpu_clock() if cpu_clock is not None else 0.0
        t0 = clock() if clock is not None else 0.0
        est = loc.on_scan(cur.scan, now)
        seconds = clock() - t0 if clock is not None else 0.0
        cpu_seconds = cpu_clock() - c0 if cpu_clock is not None else 0.0
        # What the robot reports (the building pose, `map_offset`) and the map pose.
        reported = loc.building_pose
        if est.pose is None or reported is None:  # not after set_initial_pose; keeps the types
            raise LogReplayError(f"the localiser has no pose at t={now}")
        e, nees = _pose_error(reported, loc.building_covariance, cur.pose)
        e_map, map_nees = _pose_error(est.pose, est.covariance, cur.pose)
        offset, turn, fits_better = (
            reference_check(loc, cur, est.pose) if check_reference else (math.nan, math.nan, False)
        )
        outcome = ScanOutcome(
            float(math.hypot(e[0], e[1])),
            abs(float(e[2])),
            est.state,
            nees,
            seconds,
            run[0].pose.compose(odom).distance_to(cur.pose),
            reference_offset_m=offset,
            reference_heading_offset_rad=turn,
            estimate_fits_better=fits_better,
            after_set_pose=after_set_pose,
            map_error_m=float(math.hypot(e_map[0], e_map[1])),
            map_nees=map_nees,
            wall_model=loc.wall_model.surface,
            wall_model_learnt=loc.wall_model.decided,
            reason=est.reason,
            cpu_seconds=cpu_seconds,
            view_mapped=scan_view_mapped(observed, grid, loc.config, cur),
        )
        out.append(outcome)
        if observe is not None:
            observe(loc, cur, outcome)
        after_set_pose = est.state is LocaliserState.LOST and reinit_lost
        if after_set_pose:
            # What the robot's user does ("Help me!"): a new initial pose, here the logged one.
            loc.set_initial_pose(cur.pose, now)
    return out


def _pose_error(pose: Pose2D, cov: np.ndarray, truth: Pose2D) -> tuple[np.ndarray, float]:
    """The error (x, y, yaw) of ``pose`` against ``truth`` and its NEES under ``cov``."""
    e = np.array(
        [pose.x - truth.x, pose.y - truth.y, math.remainder(pose.yaw - truth.yaw, math.tau)]
    )
    try:
        return e, float(e @ np.linalg.solve(cov, e))
    except np.linalg.LinAlgError:
        return e, math.inf


def replay_stamps(run: Sequence[LaserRecord]) -> list[float]:
    """Times [s] to replay ``run`` at: the logged timestamps, or, where a log has none (the
    Freiburg campus, Infinite Corridor, CSAIL and Örebro logs hold 0), one second per scan
    (their scans are about 1 m apart: a robot at 1 m/s)."""
    logged = [r.timestamp for r in run]
    if all(b > a for a, b in itertools.pairwise(logged)):
        return logged
    return [float(k) for k in range(len(run))]


def summarise(outcomes: Sequence[ScanOutcome]) -> dict[str, float]:
    """Figures over localised scans.

    ``scans``, ``rms_m``, ``median_m``, ``max_m``, ``rms_yaw_rad``, ``max_yaw_rad`` (every
    scan, whatever its state; of the reported pose, the building pose of `map_offset`),
    ``map_pose_rms_m`` and ``map_pose_nees_mean`` (the map pose's, navigation's: the same where
    the building pose is the map pose), ``ok_rms_m`` and ``ok_max_m`` (scans reported ok),
    ``lost_scans``, ``degraded_scans``, ``silent_failures``, ``nees_mean`` and
    ``nees_within_95`` (fraction of scans not lost whose error lies in the covariance's 95 %
    ellipsoid: 0.95 if calibrated), ``ms_median``, ``ms_p99``, ``ms_p99_tracking`` (the p99
    without the scans just after a re-set pose, whose first match runs from 25 starts),
    ``set_pose_scans`` (how many those are), ``cpu_ms_median``, ``cpu_ms_p99`` and
    ``cpu_ms_p99_tracking`` (the same in CPU time: what the work costs, without the time
    slices of other processes that a loaded machine adds to the wall clock) and
    ``odometry_only_rms_m``;
    ``seen_scans``, ``seen_rms_m``, ``seen_median_m`` and ``seen_max_m``: the scans whose view
    the map holds (`ScanOutcome.seen`, `VIEW_MAPPED_MIN`) and their error figures (nan
    without such scans): the figures of what the method claims to measure where some scans
    look where the map was never made (the Freiburg campus's revisit);
    ``wall_face_scans`` and ``wall_learnt_scans``: the fractions of scans matched with walls on
    the cell faces, and after the wall model was learnt (`Localiser.wall_model`);
    and, on the reference itself (`reference_check`), ``reference_offset_rms_m`` and
    ``reference_heading_offset_rms_rad`` (logged pose to the scan's best fit in the map near it,
    position and heading) and ``estimate_fits_better`` (fraction of scans
    whose estimate fits the scan to the map at least as well as the logged pose).
    """
    if not outcomes:
        raise LogReplayError("no scans were localised")
    err = np.array([o.error_m for o in outcomes])
    yerr = np.array([o.yaw_error_rad for o in outcomes])
    ok = np.array([o.state is LocaliserState.OK for o in outcomes])
    tracked = [o for o in outcomes if o.state is not LocaliserState.LOST]
    nees = np.array([o.nees for o in tracked]) if tracked else np.array([math.nan])
    map_nees = np.array([o.map_nees for o in tracked]) if tracked else np.array([math.nan])
    map_err = np.array([o.map_error_m for o in outcomes])
    ms = np.array([o.seconds for o in outcomes]) * 1e3
    cpu_ms = np.array([o.cpu_seconds for o in outcomes]) * 1e3
    tracking = np.array([not o.after_set_pose for o in outcomes])
    offsets = np.array([o.reference_offset_m for o in outcomes])
    seen = np.array([o.seen for o in outcomes])
    turns = np.array([o.reference_heading_offset_rad for o in outcomes])
    return {
        "scans": float(err.size),
        "rms_m": float(np.sqrt(np.mean(err**2))),
        "median_m": float(np.median(err)),
        "max_m": float(err.max()),
        "rms_yaw_rad": float(np.sqrt(np.mean(yerr**2))),
        "max_yaw_rad": float(yerr.max()),
        "ok_rms_m": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else math.nan,
        "ok_max_m": float(err[ok].max()) if ok.any() else math.nan,
        "lost_scans": float(sum(o.state is LocaliserState.LOST for o in outcomes)),
        "degraded_scans": float(sum(o.state is LocaliserState.DEGRADED for o in outcomes)),
        "silent_failures": float(sum(o.silent for o in outcomes)),
        "nees_mean": float(np.mean(nees)),
        "nees_within_95": float(np.mean(nees <= 7.815)),
        "map_pose_rms_m": float(np.sqrt(np.mean(map_err**2))),
        "map_pose_nees_mean": float(np.mean(map_nees)),
        "ms_median": float(np.median(ms)),
        "ms_p99": float(np.percentile(ms, 99)),
        "ms_p99_tracking": float(np.percentile(ms[tracking], 99)) if tracking.any() else math.nan,
        "set_pose_scans": float(np.count_nonzero(~tracking)),
        "cpu_ms_median": float(np.median(cpu_ms)),
        "cpu_ms_p99": float(np.percentile(cpu_ms, 99)),
        "cpu_ms_p99_tracking": float(np.percentile(cpu_ms[tracking], 99))
        if tracking.any()
        else math.nan,
        "odometry_only_rms_m": float(np.sqrt(np.mean([o.odometry_error_m**2 for o in outcomes]))),
        "reference_offset_rms_m": float(np.sqrt(np.nanmean(offsets**2)))
        if np.isfinite(offsets).any()
        else math.nan,
        "reference_heading_offset_rms_rad": float(np.sqrt(np.nanmean(turns**2)))
        if np.isfinite(turns).any()
        else math.nan,
        "estimate_fits_better": float(np.mean([o.estimate_fits_better for o in outcomes])),
        "seen_scans": float(np.count_nonzero(seen)),
        "seen_rms_m": float(np.sqrt(np.mean(err[seen] ** 2))) if seen.any() else math.nan,
        "seen_median_m": float(np.median(err[seen])) if seen.any() else math.nan,
        "seen_max_m": float(err[seen].max()) if seen.any() else math.nan,
        "wall_face_scans": float(np.mean([o.wall_model == "cell_face" for o in outcomes])),
        "wall_learnt_scans": float(np.mean([o.wall_model_learnt for o in outcomes])),
    }


def revisit_runs(records: list[LaserRecord], split: int, min_len: int) -> list[list[LaserRecord]]:
    """Maximal runs (>= ``min_len`` scans) after ``split`` whose poses revisit the mapped part
    (within `REVISIT_RADIUS_M` of a mapping pose); two such runs are one when every scan
    between them stays within `BRIDGE_RADIUS_M` of a mapping pose (those scans join it).

    A run is one drive through the mapped area, localised without a new initial pose. These
    logs hold a scan about every metre, so a second pass 1.1-1.4 m to the side of the first
    has scans "away" from every mapping pose: cut there, the next run began with a person's
    initial pose (0.3 m, 10 degrees) in the middle of the Infinite Corridor, and its revisit
    figure measured those restarts more than tracking. Only runs that are runs on their own
    are joined: joining short stretches of revisits into new runs, or extending runs at their
    ends to scans 1-2 m away (the robot turning into space the first pass did not see), added
    scans the localiser gets wrong (CSAIL's revisit 2 -> 20-29 cm RMS, Intel's 2.8 -> 3.0-5.6
    cm): a weakness of the localiser at the map's edge, not what a revisit measures."""
    mapped = np.array([[r.pose.x, r.pose.y] for r in records[:split]])
    later = records[split:]
    near = [
        float(np.min(np.hypot(mapped[:, 0] - r.pose.x, mapped[:, 1] - r.pose.y))) for r in later
    ]
    spans: list[tuple[int, int]] = []  # [start, end) of each run of revisits, in `later`
    start = None
    for k, d in enumerate([*near, math.inf]):
        if d < REVISIT_RADIUS_M:
            start = k if start is None else start
            continue
        if start is not None and k - start >= min_len:
            spans.append((start, k))
        start = None
    joined: list[tuple[int, int]] = []
    for a, b in spans:
        if joined and all(d < BRIDGE_RADIUS_M for d in near[joined[-1][1] : a]):
            joined[-1] = (joined[-1][0], b)
        else:
            joined.append((a, b))
    return [later[a:b] for a, b in joined]


def localise_revisits(
    path: Path,
    split_fraction: float,
    map_stride: int,
    loc_stride: int,
    seed: int = 0,
    *,
    records: list[LaserRecord],
    clock: Callable[[], float] | None = None,
    more_seeds: Sequence[int] = (),
    cpu_clock: Callable[[], float] | None = None,
) -> dict[str, float]:
    """Map the first ``split_fraction`` of the log at ``path``, localise the revisits of the rest.

    Every ``map_stride``-th scan builds the map; every ``loc_stride``-th scan of a revisit run
    (>= 10 localised scans) is localised. ``records``: the log, read (``path`` names it). Returns
    `summarise`'s figures, ``runs`` and `replay_seeds`'s (``more_seeds``).
    """
    if not 0.0 < split_fraction < 1.0 or map_stride < 1 or loc_stride < 1:
        raise LogReplayError(
            f"{path}: need 0 < split_fraction < 1 and strides >= 1, got {split_fraction}, "
            f"{map_stride}, {loc_stride}"
        )
    grid, runs = revisit_case(path, records, split_fraction, map_stride, loc_stride)
    stats = replay_seeds(grid, runs, seed, more_seeds, clock, cpu_clock)
    stats["runs"] = float(len(runs))
    return stats


def revisit_case(
    path: Path, records: list[LaserRecord], split_fraction: float, map_stride: int, loc_stride: int
) -> tuple[OccupancyGrid, list[list[LaserRecord]]]:
    """`localise_revisits`'s map and the runs it localises (every ``loc_stride``-th scan)."""
    split = int(split_fraction * len(records))
    mapping = records[:split:map_stride]
    if not mapping:
        raise LogReplayError(f"{path}: no scans to build a map from ({len(records)} records)")
    runs = revisit_runs(records, split, 10 * loc_stride)
    if not runs:
        raise LogReplayError(f"{path}: no revisit run of >= {10 * loc_stride} scans to localise")
    return map_of(mapping), [run[::loc_stride] for run in runs]


def replay_seeds(
    grid: OccupancyGrid,
    runs: Sequence[Sequence[LaserRecord]],
    seed: int,
    more_seeds: Sequence[int] = (),
    clock: Callable[[], float] | None = None,
    cpu_clock: Callable[[], float] | None = None,
) -> dict[str, float]:
    """`summarise`'s figures of ``runs`` replayed in turn (`replay_run`, one odometry noise
    stream of ``seed`` through them), and ``seeds`` and ``silent_failures_seeds``: how many
    odometry seeds were replayed and the silent failures over all of them (``seed`` and
    ``more_seeds``; those are replayed without the clock and the reference check).

    One seed's odometry noise is one draw: a silent failure can hang on a few scans (the
    Infinite Corridor's revisit has one with seed 2, none with 0, 1, 3 or 4), so the figure
    that must be 0 is counted over several. The localiser is built once for the map and
    copied for each run (`replay_run`'s ``prototype``).
    """
    prototype = Localiser(grid, log_config())
    outcomes: list[ScanOutcome] = []
    rng = np.random.default_rng(seed)
    for run in runs:
        outcomes += replay_run(
            grid, run, rng, clock=clock, prototype=prototype, cpu_clock=cpu_clock
        )
    stats = summarise(outcomes)
    silent = stats["silent_failures"]
    for other in more_seeds:
        rng = np.random.default_rng(other)
        for run in runs:
            replayed = replay_run(grid, run, rng, check_reference=False, prototype=prototype)
            silent += sum(o.silent for o in replayed)
    stats["seeds"] = float(1 + len(more_seeds))
    stats["silent_failures_seeds"] = silent
    return stats


def localise_interleaved(
    path: Path,
    stride: int,
    seed: int = 0,
    *,
    start: int = 0,
    count: int | None = None,
    records: list[LaserRecord],
    clock: Callable[[], float] | None = None,
    more_seeds: Sequence[int] = (),
    cpu_clock: Callable[[], float] | None = None,
) -> dict[str, float]:
    """Map every ``stride``-th scan of the log; localise the scans half-way between them
    (index ``≡ stride // 2`` mod ``stride``) forward in one run from the first one's pose.

    ``start`` and ``count`` restrict the method to a slice of the log (``count`` scans from
    ``start``, mapped and localised: for fast tests). ``more_seeds``: see `replay_seeds`.
    """
    grid, run = interleaved_case(path, records, stride, start, count)
    stats = replay_seeds(grid, [run], seed, more_seeds, clock, cpu_clock)
    stats["runs"] = 1.0
    return stats


def interleaved_case(
    path: Path, records: list[LaserRecord], stride: int, start: int = 0, count: int | None = None
) -> tuple[OccupancyGrid, list[LaserRecord]]:
    """`localise_interleaved`'s map and the run it localises."""
    if stride < 2:
        raise LogReplayError(f"{path}: the interleaved method needs stride >= 2, got {stride}")
    if len(records) < 2 * stride:
        raise LogReplayError(f"{path}: {len(records)} scans are too few for stride {stride}")
    end = len(records) if count is None else min(len(records), start + count)
    grid = map_of(records[start - start % stride : end : stride])
    run = [r for i, r in enumerate(records[start:end], start) if i % stride == stride // 2]
    if len(run) < 10:
        raise LogReplayError(f"{path}: fewer than 10 scans to localise in [{start}, {end})")
    return grid, run


# ------------------------------------------------------------------ maps from logged scans
# A counting ("hit / pass") occupancy grid, the frequentist form of the inverse sensor model of
# Thrun, Burgard and Fox, *Probabilistic Robotics*, ch. 9: every end point adds a hit to its
# cell, every cell a beam passes through before it adds a pass (sampled at half the resolution
# along the beam). A cell is OCCUPIED when ``hits >= min_hits`` and ``hits / (hits + passes) >=
# occupied_ratio``, FREE when it was passed and is not occupied, UNKNOWN otherwise. Vectorised
# over the beams of each scan. (Map authoring for the real-data tests: not shipped.)


class MappingError(ValueError):
    """Inputs of `grid_from_scans` are inconsistent."""


def scan_points_in_map(
    scan: LaserScan, pose: Pose2D, max_range: float | None = None
) -> npt.NDArray[np.float64]:
    """End points of the valid beams in the map frame, (N, 2) [m]."""
    pts = scan.points(max_range)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return np.column_stack(
        (pose.x + c * pts[:, 0] - s * pts[:, 1], pose.y + s * pts[:, 0] + c * pts[:, 1])
    )


def grid_from_scans(
    scans: Sequence[LaserScan],
    poses: Sequence[Pose2D],
    resolution: float,
    max_range: float = 15.0,
    margin: float = 1.0,
    min_hits: int = 2,
    occupied_ratio: float = 0.25,
) -> OccupancyGrid:
    """Build an `OccupancyGrid` from scans taken at the given sensor poses.

    ``max_range`` [m]: beams longer than this are ignored (no return is not traced either);
    ``margin`` [m] is added around the end points and poses.
    """
    if len(scans) != len(poses) or not scans:
        raise MappingError(f"need as many poses as scans (>0), got {len(scans)} and {len(poses)}")
    if not (math.isfinite(resolution) and 0.005 <= resolution <= 2.0):
        raise MappingError(f"resolution must be 0.005..2 m, got {resolution}")
    if min_hits < 1 or not 0.0 < occupied_ratio <= 1.0:
        raise MappingError("need min_hits >= 1 and 0 < occupied_ratio <= 1")
    ends = [scan_points_in_map(s, p, max_range) for s, p in zip(scans, poses, strict=True)]
    every = np.vstack([*ends, np.array([[p.x, p.y] for p in poses])])
    x0, y0 = every.min(axis=0) - margin
    x1, y1 = every.max(axis=0) + margin
    width = math.ceil((x1 - x0) / resolution)
    height = math.ceil((y1 - y0) / resolution)
    # The cells hit and passed, scan by scan, counted once at the end: a count per scan over
    # the whole grid (millions of cells on the Infinite Corridor) cost a minute per map.
    hit_cells: list[npt.NDArray[np.intp]] = []
    passed_cells: list[npt.NDArray[np.intp]] = []
    step = resolution * 0.5
    for pose, end in zip(poses, ends, strict=True):
        if end.size == 0:
            continue
        col = ((end[:, 0] - x0) / resolution).astype(np.intp)
        row = ((end[:, 1] - y0) / resolution).astype(np.intp)
        hit_cells.append(row * width + col)
        # Free space: samples from the sensor up to one cell short of each end point.
        dx, dy = end[:, 0] - pose.x, end[:, 1] - pose.y
        length = np.hypot(dx, dy)
        n_max = int(length.max() / step)
        if n_max < 1:
            continue
        t = np.arange(n_max, dtype=np.float64) * step  # [m] along the beam
        keep = t[None, :] < (length[:, None] - resolution)
        frac = t[None, :] / np.maximum(length[:, None], 1e-9)
        sx = (pose.x + frac * dx[:, None])[keep]
        sy = (pose.y + frac * dy[:, None])[keep]
        cells = ((sy - y0) / resolution).astype(np.intp) * width + ((sx - x0) / resolution).astype(
            np.intp
        )
        passed_cells.append(np.unique(cells))  # a cell counts once per scan
    hits = np.bincount(np.concatenate([*hit_cells, np.empty(0, np.intp)]), minlength=height * width)
    passes = np.bincount(
        np.concatenate([*passed_cells, np.empty(0, np.intp)]), minlength=height * width
    )
    cells_out = np.full(height * width, UNKNOWN, dtype=np.int8)
    cells_out[passes > 0] = FREE
    occupied = (hits >= min_hits) & (hits >= occupied_ratio * (hits + passes))
    cells_out[occupied] = OCCUPIED
    return OccupancyGrid(
        cells_out.reshape(height, width), resolution, float(x0), float(y0), 0.0, "<scans>"
    )
