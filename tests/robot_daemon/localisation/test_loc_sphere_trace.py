"""The see-through trace's kernel (`robot_daemon.localisation.sphere_trace`): compiled and plain
Python give the same flags and crossing ranges bit for bit, and a localiser's run after the
warm-up compiles nothing more.

Its equality with the plain numpy loop it replaced is tested in `test_loc_speed_equivalence.py`
(`trace_impossible_reference`), on the synthetic office, the ISR map and a real log here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon import jit
from robot_daemon.localisation import localiser as localiser_module
from robot_daemon.localisation import map_distance, slide_profile, sphere_trace
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import log_config, map_of, replay_run
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan
from tests.robot_daemon.localisation.test_loc_speed_equivalence import trace_impossible_reference

INTEL = Path(__file__).resolve().parents[3].parent / "shared/data/laser_logs/intel-corrected.log.gz"


def _random_case(
    rng: np.random.Generator,
) -> tuple[
    np.ndarray, np.ndarray, tuple[float, float], tuple[float, float], np.ndarray, tuple[int, int]
]:
    """A random step field (NaN cells in blobs and alone, inf border), laser and beams: lasers
    on, at the edge of and off the field, beams of any length (some within the margin)."""
    width, height = int(rng.integers(3, 60)), int(rng.integers(3, 60))
    steps = rng.uniform(0.05, 0.6, (height, width))
    steps[rng.uniform(size=steps.shape) < rng.uniform(0.0, 0.3)] = np.nan
    steps[[0, -1], :] = np.inf
    steps[:, [0, -1]] = np.inf
    laser = (float(rng.uniform(-5.0, width + 5.0)), float(rng.uniform(-5.0, height + 5.0)))
    n = int(rng.integers(0, 80))
    lengths = rng.uniform(0.0, 8.0, n)
    angles = rng.uniform(-math.pi, math.pi, n)
    points = np.column_stack((lengths * np.cos(angles), lengths * np.sin(angles)))
    heading = float(rng.uniform(-4.0, 4.0))
    cos_sin = (math.cos(heading), math.sin(heading))
    ranges = np.hypot(points[:, 0], points[:, 1])
    return points, ranges, cos_sin, laser, steps.reshape(-1), (width, height)


def test_compiled_trace_equals_its_plain_python_function() -> None:
    """Random fields, lasers and beams, with and without the depth test: the compiled trace
    and its plain-Python function (with the plain step and lookup) agree bit for bit."""
    rng = np.random.default_rng(21)
    through_seen = possible_seen = 0
    for _ in range(300):
        points, ranges, cos_sin, laser, steps, field = _random_case(rng)
        resolution = float(rng.choice([0.05, 0.1]))
        trace = (0.3, int(rng.integers(0, 40)), float(rng.choice([0.0, 0.1, 0.25])))
        args = (points, ranges, cos_sin, laser, steps, field, resolution, trace)
        got = sphere_trace.trace_rays(*args)
        with pytest.MonkeyPatch.context() as patch:
            for name in ("_step_at", "_advance"):
                patch.setattr(sphere_trace, name, jit.python_function(getattr(sphere_trace, name)))
            want = jit.python_function(sphere_trace.trace_rays)(*args)
        assert np.array_equal(got[0], want[0])
        assert np.array_equal(got[1], want[1], equal_nan=True)
        through_seen += int(np.count_nonzero(got[0]))
        possible_seen += int(np.count_nonzero(~got[0]))
    assert through_seen > 100 and possible_seen > 100  # both verdicts were compared


def trace_one_ray_at_a_time(
    points: np.ndarray,
    ranges: np.ndarray,
    cos_sin: tuple[float, float],
    laser: tuple[float, float],
    steps: np.ndarray,
    field: tuple[int, int],
    resolution: float,
    trace: tuple[float, int, float],
) -> tuple[np.ndarray, np.ndarray]:
    """`sphere_trace.trace_rays` without lanes: each ray to its end, then the next."""
    c, s = cos_sin
    margin, max_steps, depth = trace
    inv = 1.0 / resolution
    crossing = np.full(points.shape[0], np.nan)
    for i, ((sx, sy), r) in enumerate(zip(points.tolist(), ranges.tolist(), strict=True)):
        if not r - margin > 0.0:
            continue
        direction = ((c * sx - s * sy) / r * inv, (s * sx + c * sy) / r * inv)
        t = 0.0
        for _ in range(max_steps):
            t_next, through = sphere_trace._advance(
                steps, t, direction, laser, field, resolution, depth
            )
            if through:
                crossing[i] = t
                break
            if not t_next < r - margin:
                break
            t = t_next
    return ~np.isnan(crossing), crossing


def test_rays_in_lanes_trace_as_one_ray_at_a_time() -> None:
    """Rays stepping side by side (`LANES` of them, some ending early, scans of any length)
    end exactly where each traced alone ends."""
    rng = np.random.default_rng(25)
    for _ in range(300):
        points, ranges, cos_sin, laser, steps, field = _random_case(rng)
        trace = (0.3, int(rng.integers(0, 40)), 0.1)
        args = (points, ranges, cos_sin, laser, steps, field, 0.05, trace)
        got = sphere_trace.trace_rays(*args)
        want = trace_one_ray_at_a_time(*args)
        assert np.array_equal(got[0], want[0])
        assert np.array_equal(got[1], want[1], equal_nan=True)


def test_lookup_truncates_and_clips_as_numpy() -> None:
    """`sphere_trace._step_at` compiled: the cell of ``astype(np.intp)`` clipped to the field
    (negative coordinates truncate towards 0), as the plain loop's ``np.clip`` has it."""
    rng = np.random.default_rng(22)
    width, height = 17, 11
    steps = rng.uniform(0.0, 1.0, width * height)
    for _ in range(2000):
        t = float(rng.uniform(0.0, 40.0))
        dcol, drow = (float(v) for v in rng.normal(0.0, 10.0, 2))
        laser = (float(rng.uniform(-3.0, 20.0)), float(rng.uniform(-3.0, 14.0)))
        col = np.clip(np.array([laser[0] + t * dcol]).astype(np.intp), 0, width - 1)[0]
        row = np.clip(np.array([laser[1] + t * drow]).astype(np.intp), 0, height - 1)[0]
        got = sphere_trace._step_at(steps, t, dcol, drow, laser, (width, height))
        assert got == steps[row * width + col]


def _real_log_localiser() -> tuple[Localiser, list]:
    if not INTEL.is_file():
        pytest.skip(f"real laser log {INTEL} is absent (see ../shared/data/README.md)")
    records = read_laser_records(INTEL)[:400]
    return Localiser(map_of(records[:300:2]), log_config()), records


@pytest.mark.realdata
def test_trace_equals_the_plain_loop_on_a_real_log() -> None:
    """The Intel lab's scans (a map of its first 300 scans, every second one), traced at their
    logged poses and 0.1-1 m off them: the plain numpy loop's flags and ranges, bit for bit."""
    loc, records = _real_log_localiser()
    rng = np.random.default_rng(23)
    through = 0
    for record in records[1::3]:
        points = loc._scan_points(record.scan)
        p = record.pose
        for sigma in (0.0, 0.1, 1.0):
            at = Pose2D(p.x + rng.normal(0, sigma), p.y + rng.normal(0, sigma), p.yaw)
            mask, crossing = loc._trace_rays(points, at, loc.config.impossible_max_beams)
            ref_mask, ref_crossing = trace_impossible_reference(loc, points, at)
            assert np.array_equal(mask, ref_mask)
            assert np.array_equal(crossing, ref_crossing, equal_nan=True)
            through += int(np.count_nonzero(mask))
    assert through > 50


class _CountedTraces:
    """The localiser's trace kernels, counting their calls."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.calls = 0
        monkeypatch.setattr(localiser_module, "trace_rays", self._counted(sphere_trace.trace_rays))

    def _counted(self, kernel: Callable[..., object]) -> Callable[..., object]:
        def call(*args: object) -> object:
            self.calls += 1
            return kernel(*args)

        return call


def _signatures() -> tuple[int, ...]:
    kernels = (  # every kernel of the localiser (the first three: called from Python)
        sphere_trace.trace_rays,
        slide_profile.likelihood_at_poses,
        map_distance.end_points_on_map,
        sphere_trace._advance,
        sphere_trace._step_at,
    )
    return tuple(len(getattr(k, "signatures", ())) for k in kernels)


def test_a_run_after_the_warm_up_compiles_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """300 scans of the synthetic office (tracked, then kidnapped: beams through walls) after
    `jit.warm_up`: the trace ran on every scan and no kernel gained a signature."""
    jit.warm_up()
    before = _signatures()
    counted = _CountedTraces(monkeypatch)
    rng = np.random.default_rng(24)
    loc = Localiser(office_grid(), LocaliserConfig())
    truth = Pose2D(2.0, 2.0, 0.3)
    loc.on_odometry(truth, 0.0)
    loc.set_initial_pose(truth, 0.0)
    for k in range(300):
        now = 0.1 * (k + 1)
        truth = Pose2D(2.0 + 0.05 * (k % 200), 2.0 + 0.01 * (k % 100), 0.3)
        if k == 250:
            truth = Pose2D(15.0, 10.0, 2.0)  # kidnapped: the odometry does not know
        else:
            loc.on_odometry(truth, now)
        loc.on_scan(utm_scan(OFFICE_BOXES, truth, now, rng), now)
    assert counted.calls >= 300
    assert _signatures() == before
    if jit.ENABLED:
        assert before[:3] == (1, 1, 1)  # one specialisation of each kernel: the warm-up's


@pytest.mark.realdata
def test_a_real_log_replay_after_the_warm_up_compiles_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same on 300 scans of the Intel lab's log replayed as the benchmark does."""
    jit.warm_up()
    before = _signatures()
    counted = _CountedTraces(monkeypatch)
    loc, records = _real_log_localiser()
    outcomes = replay_run(loc._map_grid, records[100:400], np.random.default_rng(0), prototype=loc)
    assert len(outcomes) == 299
    assert counted.calls >= 299
    assert _signatures() == before
