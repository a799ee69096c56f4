"""Benchmark: the localiser on every real laser log in ../shared/data/laser_logs (eight CARMEN logs).

Two methods of `tests/robot_daemon/localisation/log_replay.py` (the real-data tests use the same code):

* ``revisit``: map the first half of a log with its logged (GMapping-corrected) poses, localise
  the later scans that come back to the mapped area, in runs; two runs are one where the path
  between them stays within 2 m of the first pass (`log_replay.revisit_runs`; until session 7
  such a run was cut and restarted from a person's initial pose, mid-corridor on the
  Infinite Corridor). Not every log revisits (ACES and CSAIL
  hardly do): ``reallog_<log>_revisit_scans`` is then 0 and the other revisit figures absent.
* ``whole``: every ``stride``-th scan builds the map, the scans half-way between them are
  localised forward through the *whole* log in one run (easier than a revisit: neighbouring
  scans are in the map; it covers every corridor and hall of every log).

Both start at the logged pose with a person's initial covariance (0.3 m, 10 degrees) and use
odometry made from the logged increments with 5 % scale error, 0.02 rad/m yaw bias and noise.
After a scan reported ``lost`` the localiser is given the logged pose again (the user's "Help
me!"), so ``lost_scans`` counts the losses and the errors measure tracking, not dead reckoning.
The logged poses are SLAM estimates (a few centimetres), not ground truth.

Keys ``reallog_<log>_<method>_<figure>`` with figures ``scans``, ``rms_m``, ``median_m``,
``max_m``, ``heading_rms_deg`` (every scan, whatever its state), ``ok_rms_m`` and ``ok_max_m``
(the scans reported ``ok``: what a user relies on; the rest are reported degraded or lost),
``lost_scans``, ``degraded_scans``, ``silent_failures`` (error
> 0.3 m or > 10 degrees reported ``ok``: the figure that must be 0), ``nees_mean`` (3 if the
covariance is calibrated), ``nees_within_95`` (0.95 if calibrated), ``map_pose_rms_m`` and
``map_pose_nees_mean`` (the map pose's, navigation's: the other figures are of the pose the
robot reports, the building pose of `map_offset`, which is the map pose until that filter
has learnt its odometry's walk), ``ms_median``, ``ms_p99``
(wall clock per `Localiser.on_scan` alone, covariance included: the replay's map building,
odometry and scoring are outside it), ``ms_p99_tracking`` (the p99 without the scans just
after a re-set pose: their first match runs from 25 starts, and on the Freiburg campus, 12
re-sets in 1003 scans, they alone make the p99), ``set_pose_scans`` (how many),
``cpu_ms_median``, ``cpu_ms_p99`` and ``cpu_ms_p99_tracking`` (the same in the thread's CPU
time: on a shared machine a scan's wall time also holds other processes' time slices, 4 or
8 ms each; session 14 found those made CSAIL whole's p99 of 5-6 ms, its CPU p99 1.1-1.7 ms)
and ``odometry_only_rms_m``. Every figure is of odometry seed 0 (the noise and drift of the
replay's odometry), except ``silent_failures_seeds``: the silent failures over seeds 0, 1 and 2
(`MORE_SEEDS`; one seed is one draw of the noise, and a silent failure can hang on a few scans:
the Infinite Corridor's revisit had one with seed 2 and none with seed 0). The other seeds are
replayed without the clock and the reference check, on the same map and a copy of the same
localiser. ``reallog_all_silent_failures`` sums ``silent_failures_seeds`` over every log and
method (the figure that must be 0); ``reallog_seeds`` says over how many seeds.

Three figures check the reference itself, not the localiser (`log_replay.reference_check`; they
change no other figure): ``reference_offset_rms_m`` and ``reference_heading_offset_rms_deg``, the
RMS distance and heading difference from each logged pose to the map's own best fit of its scan
near it (the scan matched from the logged pose), and
``estimate_fits_better``, the fraction of scans whose estimate explains the scan in the map at
least as well as the logged pose does. Where the offset is as large as the RMS error and the
estimate fits better in most scans, the error is mostly the reference's disagreement with the
map (Freiburg 079: offsets 3.9 / 4.4 cm, revisit / whole, against an RMS of 3.1 / 3.2 cm, the
estimate fitting better in 67 / 69 % of scans; the Infinite Corridor's second pass: the map's
fit 0.16-0.26 m ahead of the logged poses along the corridor, where the localiser follows the
map), not a localiser error; the RMS is still reported against the logged poses. The offset
also holds the matcher's slack where a scan has no sharp optimum (a corridor, sparse outdoor
returns): an indication of the floor, not a correction.

``seen_scans`` counts the scans whose view the map holds: at least 35 % of the scan's end
points (the localiser's own bar for a scan that fits, ``lost_confidence``) fall, at its logged
pose, on cells the map observed (`log_replay.view_mapped`); ``seen_rms_m``, ``seen_median_m``
and ``seen_max_m`` are the error figures over those scans alone (absent without any). The
revisit method picks scans by position, not view: the Freiburg campus's second pass drives
parts of the first one's path the other way, its 180-degree laser looking where the first pass
never looked, and those scans measure dead reckoning through an unmapped view, not a revisit.
Every other figure keeps every scan.

One more checks the logged poses without the map or the localiser's matcher
(`log_replay.reference_consistency`): ``reallog_<log>_reference_consistency_rms_m`` and
``_rms_deg``, the RMS distance and heading from each logged pose to where its scan fits the
two scans logged just before it (point-to-line ICP, scans within 0.5 m of both; about 300 per
log, ``_scans`` of them; absent where none qualifies: logs with a scan every metre). With exact
poses it is 0.3 cm and 0.05 degrees (a synthetic log); on Freiburg 079 it is 2.8 cm and 0.6
degrees between scans 0.1 m apart: the logged poses jitter against their own scans by as much
as the 3 cm target, and the replay's odometry, made from their increments, carries that jitter
too (session 14). ``reallog_<log>_reference_pass_consistency_*`` is the same between passes,
the revisit method's floor (`log_replay.reference_pass_consistency`): each scan of the second
half fitted to the two first-half scans nearest it (within 0.5 m, facing within 45 degrees),
whose logged poses built the revisit's map. ``quick`` (the smoke test) runs
only Intel and Freiburg 079 with coarser strides and seeds 0 and 1. Skipped, returning {}, when
../shared/data/laser_logs is absent.

    .venv/bin/interbot bench --only reallogs --json
    .venv/bin/python bench/bench_reallogs.py freiburg_campus   # one log (or several) alone
    .venv/bin/python bench/bench_reallogs.py csail --seed 2    # another draw of the odometry noise
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import json
import logging
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from robot_daemon import jit

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]
# The log reader and the replay method are the real-data tests' (tests/, not shipped with the
# robot): loaded by path.
_REPLAY = Path(__file__).resolve().parent.parent / "tests" / "robot_daemon" / "localisation"
_spec = importlib.util.spec_from_file_location("interbot_bench_carmen_log", _REPLAY / "carmen_log.py")  # fmt: skip
carmen_log = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
sys.modules[_spec.name] = carmen_log  # type: ignore[union-attr]  # its dataclasses look it up
_spec.loader.exec_module(carmen_log)  # type: ignore[union-attr]
read_laser_records = carmen_log.read_laser_records
_spec = importlib.util.spec_from_file_location("interbot_bench_log_replay", _REPLAY / "log_replay.py")  # fmt: skip
log_replay = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
sys.modules[_spec.name] = log_replay  # type: ignore[union-attr]  # its dataclasses look it up
_spec.loader.exec_module(log_replay)  # type: ignore[union-attr]
LogReplayError = log_replay.LogReplayError
localise_interleaved, localise_revisits = (
    log_replay.localise_interleaved,
    log_replay.localise_revisits,
)

logger = logging.getLogger(__name__)

LOGS = common.SHARED_DATA / "laser_logs"
SPLIT = 0.5  # revisit: the first half of each log builds the map
# key -> (log file stem, revisit (map stride, localisation stride), whole-log stride), full and
# quick. Most of these logs hold a scan every ~1 m of travel (Freiburg 079: every 0.1 m).
CASES: dict[str, tuple[str, tuple[int, int], int, tuple[int, int], int]] = {
    "intel": ("intel", (1, 1), 2, (2, 2), 4),
    "freiburg079": ("freiburg-079", (2, 1), 2, (6, 4), 8),
    "aces": ("aces", (1, 1), 2, (2, 2), 2),
    "csail": ("csail", (1, 1), 2, (2, 2), 2),
    "freiburg_campus": ("freiburg-campus", (1, 1), 2, (2, 2), 4),
    "infinite_corridor": ("infinite-corridor", (1, 1), 2, (2, 2), 4),
    "orebro": ("orebro", (1, 1), 2, (2, 2), 2),
    "seattle": ("seattle", (1, 1), 2, (2, 2), 2),
}
QUICK_LOGS = ("intel", "freiburg079")
# Odometry seeds replayed besides seed 0 for the silent failures (`log_replay.replay_seeds`):
# with seed 2 the Infinite Corridor's revisit had one (session 7) that seed 0 did not show.
MORE_SEEDS = (1, 2)
MORE_SEEDS_QUICK = (1,)
FIGURES = (
    "scans",
    "rms_m",
    "median_m",
    "max_m",
    "ok_rms_m",
    "ok_max_m",
    "lost_scans",
    "degraded_scans",
    "silent_failures",
    "silent_failures_seeds",
    "nees_mean",
    "nees_within_95",
    "map_pose_rms_m",
    "map_pose_nees_mean",
    "ms_median",
    "ms_p99",
    "ms_p99_tracking",
    "set_pose_scans",
    "cpu_ms_median",
    "cpu_ms_p99",
    "cpu_ms_p99_tracking",
    "odometry_only_rms_m",
    "reference_offset_rms_m",
    "estimate_fits_better",
    "wall_face_scans",
    "wall_learnt_scans",
    "seen_scans",
)

# Figures reported in degrees, from `log_replay.summarise`'s radians.
DEGREE_FIGURES = {
    "heading_rms_deg": "rms_yaw_rad",
    "reference_heading_offset_rms_deg": "reference_heading_offset_rms_rad",
}


# The figures over the scans whose view the map holds (`log_replay.ScanOutcome.seen`), present
# only where there are such scans (the figures are finite numbers, `tools/reallog_table.py`).
SEEN_FIGURES = ("seen_rms_m", "seen_median_m", "seen_max_m")


def _figures(prefix: str, stats: dict[str, float]) -> dict[str, float]:
    out = {f"{prefix}_{name}": stats[name] for name in FIGURES}
    out |= {
        f"{prefix}_{name}": stats[name]
        for name in SEEN_FIGURES
        if math.isfinite(stats.get(name, math.nan))
    }
    for name, radians in DEGREE_FIGURES.items():
        out[f"{prefix}_{name}"] = math.degrees(stats[radians])
    return out


def _consistency(prefix: str, stats: dict[str, float]) -> dict[str, float]:
    """`log_replay.reference_consistency`'s figures as ``prefix_rms_m``, ``_rms_deg`` and
    ``_scans``; only the count where no scan could be checked (the figures are finite numbers,
    `tools/reallog_table.py`)."""
    out = {f"{prefix}_scans": stats["consistency_scans"]}
    if stats["consistency_scans"] > 0:
        out[f"{prefix}_rms_m"] = stats["consistency_rms_m"]
        out[f"{prefix}_rms_deg"] = math.degrees(stats["consistency_rms_rad"])
    return out


@functools.lru_cache(maxsize=1)  # one log at a time: seeds and methods share its records
def _records(stem: str) -> list[object]:
    return list(read_laser_records(LOGS / f"{stem}-corrected.log.gz"))


def replay_one(
    key: str, method: str, seed: int = 0, quick: bool = False, more_seeds: Sequence[int] = ()
) -> dict[str, float] | None:
    """`summarise`'s figures of one log (a key of `CASES`) by one method (``revisit`` or
    ``whole``) with the odometry noise of ``seed``, and the silent failures over it and
    ``more_seeds`` (`log_replay.replay_seeds`); None where the log has no revisit run."""
    stem, revisit, whole, revisit_quick, whole_quick = CASES[key]
    path = LOGS / f"{stem}-corrected.log.gz"
    records = _records(stem)
    if method == "whole":
        return localise_interleaved(
            path,
            whole_quick if quick else whole,
            seed,
            records=records,
            clock=time.perf_counter,
            more_seeds=more_seeds,
            cpu_clock=time.thread_time,
        )
    if method != "revisit":
        raise ValueError(f"unknown method {method!r}: revisit or whole")
    map_stride, loc_stride = revisit_quick if quick else revisit
    try:
        return localise_revisits(
            path,
            SPLIT,
            map_stride,
            loc_stride,
            seed,
            records=records,
            clock=time.perf_counter,
            more_seeds=more_seeds,
            cpu_clock=time.thread_time,
        )
    except LogReplayError as exc:
        print(f"  bench_reallogs: {key}: no revisit figures ({exc})")
        return None


def run(quick: bool = False, logs: Sequence[str] | None = None, seed: int = 0) -> dict[str, float]:
    """Every log's figures (``logs``: only these keys of `CASES`, e.g. to iterate on one).

    ``seed``: the replayed odometry's noise (the bench's figures are seed 0). One seed is one
    draw of the noise: in session 8 the CSAIL revisit was 2.2-2.3 cm RMS with seeds 0, 1 and 3
    and lost once, 23-37 cm RMS (not silent), with seeds 2, 4, 5 and 6, and Örebro's whole log
    21 cm, lost once, with seed 2; since the trusted branch and the heading starts
    (`Localiser._match_trusted`, `_wide_heading_match`) 2.2-3.3 and 2.4-2.7 cm on seeds 0-6,
    never lost. Compare changes on several.
    The silent failures are counted over ``seed`` and the `MORE_SEEDS` after it (``seed + 1``,
    ``seed + 2``: `log_replay.replay_seeds`).
    """
    unknown = sorted(set(logs or ()) - set(CASES))
    if unknown:
        raise ValueError(f"unknown log(s) {unknown}: choose from {sorted(CASES)}")
    if not LOGS.is_dir():
        print(f"  bench_reallogs skipped: {LOGS} is absent (see ../shared/data/README.md)")
        return {}
    out: dict[str, float] = {}
    silent = 0.0
    jit.warm_up()  # the kernels compiled or loaded before the clock, as the daemon does
    with common.quiet_logs():
        for key, (stem, *_) in CASES.items():
            if (quick and key not in QUICK_LOGS) or (logs and key not in logs):
                continue
            if not (LOGS / f"{stem}-corrected.log.gz").is_file():
                print(f"  bench_reallogs: {stem} is absent, {key} skipped")
                continue
            for method in ("revisit", "whole"):
                more = [seed + k for k in (MORE_SEEDS_QUICK if quick else MORE_SEEDS)]
                stats = replay_one(key, method, seed, quick, more)
                if stats is None:
                    out[f"reallog_{key}_{method}_scans"] = 0.0
                    continue
                out |= _figures(f"reallog_{key}_{method}", stats)
                silent += stats["silent_failures_seeds"]
            records = _records(stem)
            out |= _consistency(
                f"reallog_{key}_reference_consistency", log_replay.reference_consistency(records)
            )
            out |= _consistency(
                f"reallog_{key}_reference_pass_consistency",
                log_replay.reference_pass_consistency(records, int(SPLIT * len(records))),
            )
    out["reallog_all_silent_failures"] = silent
    out["reallog_seeds"] = 1.0 + len(MORE_SEEDS_QUICK if quick else MORE_SEEDS)
    return out


def _arguments(argv: Sequence[str]) -> argparse.Namespace:
    """The command line ``[log ...] [--seed N] [--surface learn|cell_centre|cell_face]``
    (``logs``, ``seed``, ``surface``; None: the daemon's wall model, `log_replay.REPLAY_SURFACE`).
    A bad one exits with argparse's usage message, never a traceback."""
    parser = argparse.ArgumentParser(
        prog="bench_reallogs.py",
        description="The localiser on every real laser log (or the logs named).",
    )
    parser.add_argument("logs", nargs="*", metavar="LOG", help=f"only these: {', '.join(CASES)}")
    parser.add_argument("--seed", type=int, default=0, help="the replayed odometry's noise seed")
    parser.add_argument(
        "--surface",
        choices=("learn", "cell_centre", "cell_face"),
        help="the wall model (default: the daemon's)",
    )
    args = parser.parse_args(list(argv))
    unknown = sorted(set(args.logs) - set(CASES))
    if unknown:
        parser.error(f"unknown log(s) {', '.join(unknown)}: choose from {', '.join(CASES)}")
    return args


if __name__ == "__main__":
    _args = _arguments(sys.argv[1:])
    if _args.surface is not None:
        log_replay.REPLAY_SURFACE = _args.surface
    print(
        json.dumps(run(logs=_args.logs or None, seed=_args.seed), indent=2)
    )  # command-line output
