"""Silent failures and RMS on the real laser logs over several odometry seeds (issue 12).

``interbot bench --only reallogs`` replays each log with the odometry noise of seed 0 (and,
since session 8, counts silent failures over seeds 0-2); this tool replays every log, both
methods (``revisit``, ``whole``), for any seeds and prints one JSON line per log, method and
seed as it goes, with the scans reported ok while more than 0.3 m or 10 degrees off (their
index in the replayed run, error, state sequence around them and NEES) and the RMS over the
scans whose view the map holds (``seen_rms_m`` over ``seen_scans``)::

    .venv/bin/python tools/reallog_seeds.py                      # every log, seeds 0-4
    .venv/bin/python tools/reallog_seeds.py --seeds 2 infinite_corridor

Slow (each seed replays every log: ~5 min on a quiet machine). Not shipped with the robot.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("logs", nargs="*", help="keys of bench_reallogs.CASES (default: all)")
    parser.add_argument("--seeds", default="0-4", help="e.g. 0-4 or 0,2")
    parser.add_argument("--methods", default="revisit,whole")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))  # a tool run from the checkout: the bench loads the tests'
    from interbot_cli import bench as bench_cli

    reallogs = bench_cli.load(REPO / "bench" / "bench_reallogs.py")
    seeds = _seeds(args.seeds)
    logs = args.logs or list(reallogs.CASES)
    for key in logs:
        for method in args.methods.split(","):
            for seed in seeds:
                t0 = time.perf_counter()
                stats = reallogs.replay_one(key, method, seed)
                if stats is None:
                    continue
                line = {"log": key, "method": method, "seed": seed}
                line |= {
                    k: round(stats[k], 4)
                    for k in ("scans", "rms_m", "max_m", "silent_failures", "degraded_scans")
                }
                # the RMS over the scans whose view the map holds (`log_replay.ScanOutcome.seen`)
                line |= {k: round(stats[k], 4) for k in ("seen_scans", "seen_rms_m")}
                line["lost_scans"] = stats["lost_scans"]
                line["seconds"] = round(time.perf_counter() - t0, 1)
                print(json.dumps(line), flush=True)  # command-line output
    return 0


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


if __name__ == "__main__":
    raise SystemExit(main())
