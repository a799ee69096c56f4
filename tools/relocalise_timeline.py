"""What held a relocalisation back? A per-scan timeline of the relocaliser's decision (issue 16).

Runs the kidnap scenario (or its cold starts) exactly as ``interbot scenario kidnap`` does and,
on every scan the relocaliser decides on, records its candidates against the simulator's true
laser pose (measurement only: nothing of it reaches the robot) and why nothing was accepted.
For each search attempt it prints, in seconds from the attempt's start:

- ``cand``: the truth first tracked as a candidate (within 0.3 m, 0.2 rad);
- ``top``: first ranked best among the live candidates;
- ``sbest``: first the last search's verified best (only that one may be accepted);
- ``clear``: first the best with nothing but ``ripening`` (streak, time) in the way;
- ``accept``: the attempt ended with a pose (``WRONG`` if far from the truth);
- then the runs of what blocked the decision, ``reason@t0-t1``, and the turning intervals;
- with ``--only N`` every scan of attempt N, with the truth's and the strongest rival's
  expected-scan agreement (``match/long/beams``, ``V``: vetoed in the attempt).

Before the attempts, one line per kidnap (or cold start): standing or driving, the scenario's
record and the attempts that belong to it. The attempt's reason says which case it is: a cold
start with the operator's "Relocalise" pressed at power-on (the scenario's default) searches as
``request`` (a command: it may turn); with ``--idle-at-power-on`` as ``start-up`` (it searches
standing still); a kidnap as ``lost`` or ``kidnap`` (it turns only once a leg is waiting).

    python tools/relocalise_timeline.py --cold-start --seed 2 [--idle-at-power-on]
    python tools/relocalise_timeline.py --map ../shared/data/maps/willow.yaml \
        --topo maps/willow_topo.yaml --seed 1 [--only 3] [--idle-after-kidnap]
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from interbot_core.geometry import Pose2D, angle_diff
from robot_daemon.localisation import relocaliser as rl
from robot_daemon.scenarios import kidnap as kd
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem

TRUTH_M = 0.3
TRUTH_RAD = 0.2


@dataclass
class Attempt:
    since: float
    reason: str
    system: int  # id of the simulated system (one per cold start)
    rows: list[dict[str, Any]] = field(default_factory=list)
    result: Pose2D | None = None
    result_error: float | None = None


_attempts: list[Attempt] = []
_system: list[SimulatedSystem] = []
# (teleport time, standing, record, attempts before it) per kidnap or cold start
_trials: list[tuple[float, bool, kd.KidnapRecord, int]] = []
_orig_watch = kd._watch


def _traced_watch(
    system: SimulatedSystem, record: kd.KidnapRecord, start: float, *args: Any
) -> None:
    _trials.append((start, record.standing, record, len(_attempts)))
    _orig_watch(system, record, start, *args)


class _TracedSystem(SimulatedSystem):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _system[:] = [self]


def _truth_laser() -> Pose2D:
    system = _system[0]
    return system.sim.true_pose().compose(system.stack.config.laser_mount)


def _is_truth(pose: Pose2D, truth: Pose2D) -> bool:
    return pose.distance_to(truth) <= TRUTH_M and abs(angle_diff(pose.yaw, truth.yaw)) <= TRUTH_RAD


_orig_decide = rl.Relocaliser._decide


def _traced_decide(self: rl.Relocaliser, now: float) -> Pose2D | None:
    before = self.last_failure
    self.last_failure = ""
    pose = _orig_decide(self, now)
    why = self.last_failure or ("ripening" if self.ripening else "")
    if pose is None and not self.last_failure:
        self.last_failure = before
    last = _attempts[-1] if _attempts else None
    if last is None or (last.since, last.system, last.result) != (self.since, id(_system[0]), None):
        _attempts.append(Attempt(self.since, self.reason, id(_system[0])))
    att = _attempts[-1]
    truth = _truth_laser()
    cands = list(self._candidates) if pose is None else []
    alive = sorted((c for c in cands if c.streak > 0), key=lambda c: -c.quality)
    truth_cand = next((c for c in cands if _is_truth(c.pose, truth)), None)
    best = alive[0] if alive else None
    rival = max((c for c in cands if c is not truth_cand), key=lambda c: c.quality, default=None)
    vdiff = vwin = None
    if truth_cand is not None and rival is not None:
        k = min(len(truth_cand.view_quality), len(rival.view_quality), len(self._views))
        if k:
            d = [
                a - b
                for a, b in zip(truth_cand.view_quality[-k:], rival.view_quality[-k:], strict=True)
            ]
            vdiff, vwin = sum(d) / k, sum(x >= 0 for x in d) / k
    beams = {}
    if pose is None:  # the scan against the map's prediction (cached per scan: no side effect)
        for name, cand in (("truth", truth_cand), ("rival", rival)):
            agreement = None if cand is None else self._beams(cand)
            if agreement is not None:
                veto = "V" if self._is_vetoed(cand.pose) else ""
                beams[name] = f"{agreement.match:.2f}/{agreement.long:.3f}/{agreement.beams}{veto}"
    if pose is not None:
        why = "accepted"
        att.result = pose
        att.result_error = pose.distance_to(truth)
    att.rows.append(
        {
            "t": now - self.since,
            "why": why or "no candidate",
            "n": len(cands),
            "truth_cand": truth_cand is not None,
            "truth_q": None if truth_cand is None else truth_cand.quality,
            "truth_streak": None if truth_cand is None else truth_cand.streak,
            "truth_top": best is not None and truth_cand is best,
            "truth_sbest": truth_cand is not None and self._search_best is truth_cand,
            "best_q": None if best is None else best.quality,
            "rival_q": None if rival is None else rival.quality,
            "rival_m": None if rival is None else rival.pose.distance_to(truth),
            "vdiff": vdiff,
            "vwin": vwin,
            "turning": self.turning,
            "views": len(self._views),
            "exhaustive": self._exhaustive,
            "beams": " ".join(f"{k}={v}" for k, v in beams.items()) or "-",
        }
    )
    return pose


def _first(rows: list[dict[str, Any]], key: str) -> str:
    t = next((r["t"] for r in rows if r[key]), None)
    return "-" if t is None else f"{t:.1f}"


def _runs(rows: list[dict[str, Any]], key: str) -> list[tuple[Any, float, float]]:
    out: list[tuple[Any, float, float]] = []
    for r in rows:
        if out and out[-1][0] == r[key]:
            out[-1] = (r[key], out[-1][1], r["t"])
        else:
            out.append((r[key], r["t"], r["t"]))
    return out


def report(att: Attempt, verbose: bool) -> str:
    rows = att.rows
    for r in rows:
        r["clear"] = r["truth_top"] and r["why"] in ("ripening", "accepted")
    if att.result is None:
        end = "none"
    else:
        assert att.result_error is not None
        mark = "WRONG " if att.result_error > kd.WRONG_M else ""
        end = f"{mark}{rows[-1]['t']:.1f} ({att.result_error:.2f} m)"
    head = (
        f"[{att.reason} at {att.since:.1f}] cand {_first(rows, 'truth_cand')}"
        f"  top {_first(rows, 'truth_top')}  sbest {_first(rows, 'truth_sbest')}"
        f"  clear {_first(rows, 'clear')}  accept {end}"
    )
    blocks = " ".join(f"{w}@{a:.1f}-{b:.1f}" for w, a, b in _runs(rows, "why"))
    turns = " ".join(f"{a:.1f}-{b:.1f}" for w, a, b in _runs(rows, "turning") if w)
    lines = [head, f"    blocked: {blocks}", f"    turning: {turns or '-'}"]
    if verbose:
        for r in rows:
            lines.append(
                "      t={t:5.1f} {why:42s} n={n} truth q={tq} streak={ts} top={truth_top:d} "
                "sbest={truth_sbest:d} best={bq} rival={rq} turn={turning:d} views={views} "
                "exh={exhaustive:d} rival_m={rm} vdiff={vd} vwin={vw} match/long/n {beams}".format(
                    rm="-" if r["rival_m"] is None else f"{r['rival_m']:.1f}",
                    vd="-" if r["vdiff"] is None else f"{r['vdiff']:.3f}",
                    vw="-" if r["vwin"] is None else f"{r['vwin']:.2f}",
                    tq="-" if r["truth_q"] is None else f"{r['truth_q']:.2f}",
                    ts=r["truth_streak"],
                    bq="-" if r["best_q"] is None else f"{r['best_q']:.2f}",
                    rq="-" if r["rival_q"] is None else f"{r['rival_q']:.2f}",
                    **r,
                )
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--map", type=Path, default=Path("maps/isr_floor0.yaml"))
    parser.add_argument("--topo", type=Path, default=Path("maps/isr_floor0_topo.yaml"))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--cold-start", action="store_true")
    parser.add_argument(
        "--idle-after-kidnap", action="store_true", help="no next leg after a standing kidnap"
    )
    parser.add_argument(
        "--idle-at-power-on", action="store_true", help='no "Relocalise" at a cold start'
    )
    parser.add_argument("--only", type=int, default=None, help="print attempt N in detail")
    parser.add_argument("--count", type=int, default=None, help="trials (default: scenario's)")
    args = parser.parse_args()
    options = replace(
        ScenarioOptions(map_yaml=args.map, topo_yaml=args.topo, seed=args.seed),
        cold_start=args.cold_start,
        idle_after_kidnap=args.idle_after_kidnap,
        idle_at_power_on=args.idle_at_power_on,
    )
    rl.Relocaliser._decide = _traced_decide  # type: ignore[method-assign]
    kd.SimulatedSystem = _TracedSystem  # type: ignore[misc]
    kd._watch = _traced_watch
    result = kd.run(options, args.count)
    print(result.table)
    for k, (start, standing, rec, first) in enumerate(_trials):
        last = _trials[k + 1][3] if k + 1 < len(_trials) else len(_attempts)
        mine = [f"#{i}" for i in range(first, last) if _attempts[i].since >= start - 1e-6]
        print(
            f"trial {k} at {start:.1f} ({'standing' if standing else 'driving'}): "
            f"detect {rec.detect_s} relocalise {rec.relocalise_s} wrong {rec.wrong} "
            f"help {rec.help} attempts {' '.join(mine) or '-'}"
        )
    for i, att in enumerate(_attempts):
        print(f"#{i} " + report(att, args.only == i))
    if any(
        math.isfinite(a.result_error or 0.0) and (a.result_error or 0.0) > kd.WRONG_M
        for a in _attempts
    ):
        print("WRONG relocalisation(s) above")


if __name__ == "__main__":
    main()
