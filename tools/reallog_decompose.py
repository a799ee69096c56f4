"""Where a real log's RMS comes from: the reference's disagreement with the map, or the localiser.

The real-log bench (`bench/bench_reallogs.py`) scores each localised scan against its logged
pose, a SLAM estimate, not ground truth. This tool replays one log and method the bench's way
(`log_replay.revisit_case` / `interleaved_case`, `replay_run`, the bench's strides and odometry
seed) and, for every localised scan, splits the error of the localiser's map pose ``x̂`` against
the logged pose ``x_ref`` at the map's own best fit ``x_fit`` of the scan near the logged pose
(`log_replay.reference_fit`: the scan matched on every level from the logged pose)::

    x̂ - x_ref = (x_fit - x_ref) + (x̂ - x_fit)
                 reference offset    the estimate's distance to the map's fit

and classes the scan with a tolerance ``tau`` (default one map cell, 5 cm):

* ``agree``: both parts within ``tau`` (the few centimetres no method removes);
* ``reference`` (a): the map's fit is more than ``tau`` off the logged pose, the estimate within
  ``tau`` of the fit: the estimate follows the map; no localiser of this map could be nearer;
* ``localiser`` (b): the map's fit agrees with the logged pose, the estimate does not: the
  localiser's own error;
* ``both``: the fit is off the logged pose and the estimate off the fit;
* ``look-alike``: the estimate is off the fit but explains the scan as well (a score ratio of
  at least `ALIKE`): the map cannot tell the two apart (a featureless corridor, where the fit
  from the logged pose is the matcher's slack as much as an optimum): only the odometry can;
* ``unmatched``: the scan fits the map nowhere near the logged pose (hit fraction at the fit
  below `MIN_HIT`: outdoors most returns lie beyond what the map holds): no fit to judge by,
  the localiser runs on odometry (its error here is counted as its own).

The RMS is split over the classes (``sqrt(sum of e² in the class / N)``: the parts add in
quadrature to the RMS), for the reported pose (the building pose, `map_offset`: the bench's
figure) and the map pose. The stretches where the localiser's own part (``|x̂ - x_fit|²`` in the
classes ``localiser``, ``both`` and ``look-alike``, ``|x̂ - x_ref|²`` in ``unmatched``) adds up
most are printed with their log indices, states and reasons, and per scan (``--scans``) the
parts, the heading errors, the score ratio, the hit fractions at the fit and the estimate, the
reported sigma, the error of the previous estimate moved by the odometry alone (``pred``: above
the error where the match helped) and of the last ok estimate carried by the raw odometry
(``dead-reckoning``)::

    .venv/bin/python tools/reallog_decompose.py freiburg_campus whole
    .venv/bin/python tools/reallog_decompose.py infinite_corridor revisit --top 5 --scans

``--drift on`` / ``off`` replays with the localiser's heading-drift state
(`odometry_yaw_bias`) switched on or off whatever its default, to compare the two scan by scan
(``--json``: each scan's parts as a JSON line).

Not shipped with the robot; a minute or two per log and method.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
CLASSES = ("agree", "reference", "localiser", "both", "look-alike", "unmatched")
# A scan fits the map nowhere near when its hit fraction at the map's fit is below this (the
# localiser's own `LocaliserConfig.lost_confidence`: a bad scan).
MIN_HIT = 0.35
# The estimate explains the scan as well as the map's fit when its score (mean likelihood)
# is at least this fraction of the fit's: the map cannot tell the two apart.
ALIKE = 0.98
OWN = ("localiser", "both", "look-alike", "unmatched")  # the classes a stretch is made of


@dataclass(frozen=True)
class ScanPart:
    """One localised scan's error and its parts (map frame; [m])."""

    log_index: int  # the record's index in the log
    run: int  # which replayed run
    index: int  # its index in the run
    state: str
    reason: str
    error_m: float  # the reported (building) pose against the logged pose
    map_error_m: float  # the map pose against the logged pose
    reference_offset_m: float  # the map's fit against the logged pose
    estimate_to_fit_m: float  # the map pose against the map's fit
    score: float  # fit at the estimate / fit at the map's fit
    sigma_m: float  # the reported covariance's largest position sigma
    odometry_error_m: float  # dead reckoning alone from the run's start
    # The last scan reported ok, its map pose carried by the replay's odometry alone (what
    # dead reckoning through the stretch since would have made) against the logged pose.
    dead_reckoning_m: float
    hit_fit: float  # hit fraction of the scan at the map's fit (`Localiser._hit_fraction`)
    hit_estimate: float  # ... at the map pose
    heading_error_deg: float  # the map pose's heading against the logged pose's
    fit_heading_deg: float  # the map's fit's heading against the logged pose's
    # The previous scan's map pose moved by the replay's odometry step alone, against the
    # logged pose: above ``map_error_m`` where this scan's match helped, below where it hurt.
    predicted_error_m: float

    def kind(self, tau: float, min_hit: float = MIN_HIT, alike: float = ALIKE) -> str:
        """The scan's class (the module's docstring): ``tau`` [m], the agreement tolerance;
        ``min_hit``, the hit fraction at the map's fit below which the scan fits the map
        nowhere near; ``alike``, the score ratio at or above which the estimate explains the
        scan as well as the map's fit does."""
        if not self.hit_fit >= min_hit:
            return "unmatched"
        ref = self.reference_offset_m > tau
        if not self.estimate_to_fit_m > tau:
            return "reference" if ref else "agree"
        if self.score >= alike:
            return "look-alike"
        return "both" if ref else "localiser"


def replay(key: str, method: str, seed: int, drift: bool | None = None) -> list[ScanPart]:
    """Every localised scan of log ``key`` (a key of `bench_reallogs.CASES`) by ``method``
    (``revisit`` or ``whole``), the bench's map, runs and odometry seed (`decompose`;
    ``drift``: the heading-drift state on or off, None: the default)."""
    sys.path.insert(0, str(REPO))  # a tool run from the checkout: the bench loads the tests'
    from interbot_cli import bench as bench_cli
    from robot_daemon import jit
    from tests.robot_daemon.localisation import log_replay

    reallogs = bench_cli.load(REPO / "bench" / "bench_reallogs.py")
    stem, revisit, whole, _, _ = reallogs.CASES[key]
    path = reallogs.LOGS / f"{stem}-corrected.log.gz"
    records = reallogs._records(stem)
    if method == "whole":
        grid, run = log_replay.interleaved_case(path, records, whole)
        runs = [run]
    else:
        grid, runs = log_replay.revisit_case(path, records, reallogs.SPLIT, *revisit)
    where = {id(r): k for k, r in enumerate(records)}
    jit.warm_up()
    return decompose(grid, runs, np.random.default_rng(seed), lambda r: where[id(r)], drift)


def decompose(
    grid: Any,
    runs: Sequence[Sequence[Any]],
    rng: np.random.Generator,
    index_of: Any,
    drift: bool | None = None,
) -> list[ScanPart]:
    """`log_replay.replay_run` of each of ``runs`` in ``grid`` in turn (one odometry stream
    from ``rng``, the localiser of `log_replay.log_config`, its heading-drift state set to
    ``drift`` unless None), every scan's `ScanPart` (``index_of(record)``: its index in the
    log)."""
    from tests.robot_daemon.localisation import log_replay

    prototype = log_replay.Localiser(grid, localiser_config(drift))
    parts: list[ScanPart] = []
    for n, run in enumerate(runs):
        watch = _Watch(n, run[0].pose, index_of, parts)
        log_replay.replay_run(
            grid, run, rng, check_reference=False, prototype=prototype, observe=watch
        )
    return parts


def localiser_config(drift: bool | None = None) -> Any:
    """The replay's localiser configuration (`log_replay.log_config`) with its heading-drift
    state (`odometry_yaw_bias.enabled`) set to ``drift`` (None: as it is)."""
    import msgspec

    from tests.robot_daemon.localisation import log_replay

    config = log_replay.log_config()
    if drift is None:
        return config
    yaw_bias = msgspec.structs.replace(config.odometry_yaw_bias, enabled=drift)
    return msgspec.structs.replace(config, odometry_yaw_bias=yaw_bias)


class _Watch:
    """`replay_run`'s observer: each scan's `ScanPart` appended to ``parts``."""

    def __init__(self, run: int, start: Any, index_of: Any, parts: list[ScanPart]) -> None:
        self.run, self.index_of, self.parts = run, index_of, parts
        self.count = 0
        self.last_ok: tuple[Any, Any] = (start, None)  # the last ok map pose, odometry there
        self.previous: tuple[Any, Any] = (start, None)  # the previous map pose and odometry

    def __call__(self, loc: Any, record: Any, outcome: Any) -> None:
        from tests.robot_daemon.localisation import log_replay

        self.count += 1
        est = loc.pose
        odom = loc._odom  # the replay's odometry (private: a diagnostic tool)
        carried = self.last_ok[0].compose(odom.relative_to(self.last_ok[1] or odom))
        predicted = self.previous[0].compose(odom.relative_to(self.previous[1] or odom))
        lost = outcome.state == "lost"  # the replay then sets the logged pose again
        self.previous = (record.pose if lost else est, odom)
        if outcome.state == "ok" or lost:
            self.last_ok = (record.pose if lost else est, odom)
        offset = to_fit = score = hit_fit = hit_est = fit_turn = math.nan
        fit = log_replay.reference_fit(loc, record)
        if fit is not None:
            optimum, points = fit
            offset = optimum.distance_to(record.pose)
            to_fit = est.distance_to(optimum)
            best = log_replay.map_fit(loc, points, optimum)
            score = log_replay.map_fit(loc, points, est) / best if best > 0 else math.nan
            hit_fit = loc._hit_fraction(points, optimum)
            hit_est = loc._hit_fraction(points, est)
            fit_turn = math.degrees(math.remainder(optimum.yaw - record.pose.yaw, math.tau))
        cov = loc.covariance
        self.parts.append(
            ScanPart(
                self.index_of(record),
                self.run,
                self.count,
                str(outcome.state),
                outcome.reason,
                outcome.error_m,
                outcome.map_error_m,
                offset,
                to_fit,
                score,
                math.sqrt(max(float(np.linalg.eigvalsh(cov[:2, :2])[-1]), 0.0)),
                outcome.odometry_error_m,
                carried.distance_to(record.pose),
                hit_fit,
                hit_est,
                math.degrees(math.remainder(est.yaw - record.pose.yaw, math.tau)),
                fit_turn,
                predicted.distance_to(record.pose),
            )
        )


def split(parts: list[ScanPart], tau: float) -> dict[str, dict[str, float]]:
    """Per class: scans, and the parts of the RMS (reported and map pose) and of the RMS of the
    estimate's distance to the fit and of the reference offset."""
    n = len(parts)
    out: dict[str, dict[str, float]] = {}
    for kind in (*CLASSES, "all"):
        sel = [p for p in parts if kind in ("all", p.kind(tau))]
        out[kind] = {
            "scans": float(len(sel)),
            "rms_part_m": math.sqrt(sum(p.error_m**2 for p in sel) / n),
            "map_rms_part_m": math.sqrt(sum(p.map_error_m**2 for p in sel) / n),
            "to_fit_rms_part_m": math.sqrt(sum(_finite(p.estimate_to_fit_m) ** 2 for p in sel) / n),
            "offset_rms_part_m": math.sqrt(
                sum(_finite(p.reference_offset_m) ** 2 for p in sel) / n
            ),
        }
    return out


def stretches(parts: list[ScanPart], tau: float, gap: int = 2) -> list[list[ScanPart]]:
    """Runs of scans of the classes `OWN` in one replayed run, joined
    across up to ``gap`` other scans, largest sum of ``|x̂ - x_fit|²`` first."""
    out: list[list[ScanPart]] = []
    current: list[ScanPart] = []
    last = -math.inf
    run = -1
    for k, p in enumerate(parts):
        if p.kind(tau) not in OWN:
            continue
        if current and (p.run != run or k - last > gap + 1):
            out.append(current)
            current = []
        if current:
            current += parts[int(last) + 1 : k]  # the scans between, for the story
        current.append(p)
        last, run = k, p.run
    if current:
        out.append(current)
    return sorted(out, key=lambda s: -sum(_own(p, tau) ** 2 for p in s))


def _own(p: ScanPart, tau: float) -> float:
    kind = p.kind(tau)
    if kind == "unmatched":  # no fit to judge by: the error itself
        return p.map_error_m
    return _finite(p.estimate_to_fit_m) if kind in OWN else 0.0


def _finite(x: float) -> float:
    return x if math.isfinite(x) else 0.0


def describe(stretch: list[ScanPart], tau: float, n: int) -> str:
    """One stretch: where, how much of the RMS, its states and reasons, the numbers."""
    own = math.sqrt(sum(_own(p, tau) ** 2 for p in stretch) / n)
    states = " ".join(f"{s}x{c}" for s, c in Counter(p.state for p in stretch).items())
    reasons = Counter(_short(p.reason) for p in stretch if p.reason)
    lines = [
        f"log {stretch[0].log_index}-{stretch[-1].log_index} (run {stretch[0].run} scans "
        f"{stretch[0].index}-{stretch[-1].index}, {len(stretch)} scans): own part "
        f"{100 * own:.2f} cm of the RMS; max error {100 * max(p.error_m for p in stretch):.1f} cm; "
        f"{states}",
        "    reasons: " + "; ".join(f"{r} x{c}" for r, c in reasons.most_common(4)),
    ]
    for p in stretch:
        lines.append(
            f"    {p.log_index:5d} {p.state:9s} err {100 * p.error_m:6.1f} map {100 * p.map_error_m:6.1f} "
            f"ref {100 * p.reference_offset_m:6.1f} to-fit {100 * p.estimate_to_fit_m:6.1f} "
            f"pred {100 * p.predicted_error_m:6.1f} yaw {p.heading_error_deg:5.1f} "
            f"fit-yaw {p.fit_heading_deg:5.1f} "
            f"score {p.score:4.2f} hit fit/est {p.hit_fit:4.2f} {p.hit_estimate:4.2f} "
            f"sigma {100 * p.sigma_m:5.1f} dead-reckoning {100 * p.dead_reckoning_m:6.1f} "
            f"{_short(p.reason)}"
        )
    return "\n".join(lines)


def _short(reason: str) -> str:
    """A reason without its numbers (to count alike ones)."""
    return reason.split(" (")[0] if reason else ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log", help="a key of bench_reallogs.CASES, e.g. freiburg_campus")
    parser.add_argument("method", choices=("revisit", "whole"))
    parser.add_argument("--seed", type=int, default=0, help="the replayed odometry's noise seed")
    parser.add_argument("--tau", type=float, default=0.05, help="[m] agreement tolerance")
    parser.add_argument("--top", type=int, default=6, help="stretches printed")
    parser.add_argument("--scans", action="store_true", help="list each stretch's scans")
    parser.add_argument("--json", action="store_true", help="every scan as a JSON line too")
    parser.add_argument(
        "--drift",
        choices=("on", "off"),
        help="the localiser's heading-drift state (odometry_yaw_bias) on or off (default: as set)",
    )
    args = parser.parse_args(argv)
    drift = None if args.drift is None else args.drift == "on"
    parts = replay(args.log, args.method, args.seed, drift)
    n = len(parts)
    table = split(parts, args.tau)
    drifting = "" if drift is None else f", heading-drift state {args.drift}"
    print(
        f"{args.log} {args.method} seed {args.seed}{drifting}: {n} scans, "
        f"tau {100 * args.tau:.0f} cm"
    )
    print("class       scans  RMS part (reported / map pose)  to-fit part  ref-offset part  [cm]")
    for kind, row in table.items():
        print(
            f"{kind:10s} {int(row['scans']):6d}  {100 * row['rms_part_m']:8.2f} / "
            f"{100 * row['map_rms_part_m']:6.2f}         {100 * row['to_fit_rms_part_m']:8.2f}"
            f"     {100 * row['offset_rms_part_m']:8.2f}"
        )
    by_state = Counter((p.state, p.kind(args.tau)) for p in parts)
    print("state x class: " + ", ".join(f"{s}/{k} {c}" for (s, k), c in sorted(by_state.items())))
    for s in stretches(parts, args.tau)[: args.top]:
        text = describe(s, args.tau, n)
        print(text if args.scans else "\n".join(text.splitlines()[:2]))
    if args.json:
        for p in parts:
            print(json.dumps(p.__dict__ | {"class": p.kind(args.tau)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
