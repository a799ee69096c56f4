"""Benchmark: localisation error on real laser logs (Intel Research Lab, Freiburg building 079).

The method is `robot_daemon.localisation.log_replay.localise_revisits`, the same as the
real-data tests (tests/robot_daemon/localisation/test_loc_realdata.py): map the first half of a
log with its logged (GMapping-corrected) poses, localise the scans that revisit the mapped area
with drifting, noisy odometry, and compare with the logged poses (SLAM estimates, not ground
truth). Keys ``reallog_<log>_<figure>``. ``quick`` uses coarser strides (fewer scans). Skipped,
returning {}, when ../shared/data/laser_logs is absent.

    .venv/bin/interbot bench --only reallogs --json
"""

from __future__ import annotations

import importlib.util
import json
import logging
import math
from pathlib import Path

from robot_daemon.localisation.log_replay import localise_revisits

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

logger = logging.getLogger(__name__)

LOGS = common.SHARED_DATA / "laser_logs"
SPLIT = 0.5  # first half of each log builds the map
# key -> (log file stem, (map stride, localisation stride), quick strides); the full strides
# are the real-data tests'.
CASES = {
    "intel": ("intel", (2, 1), (4, 2)),
    "freiburg079": ("freiburg-079", (6, 4), (12, 8)),
}


def run(quick: bool = False) -> dict[str, float]:
    if not LOGS.is_dir():
        print(f"  bench_reallogs skipped: {LOGS} is absent (see ../shared/data/README.md)")
        return {}
    out: dict[str, float] = {}
    with common.quiet_logs():
        for key, (stem, full, fast) in CASES.items():
            path = LOGS / f"{stem}-corrected.log.gz"
            if not path.is_file():
                print(f"  bench_reallogs: {path} is absent, {key} skipped")
                continue
            map_stride, loc_stride = fast if quick else full
            stats = localise_revisits(path, SPLIT, map_stride, loc_stride)
            prefix = f"reallog_{key}"
            out[f"{prefix}_rms_m"] = stats["rms_m"]
            out[f"{prefix}_median_m"] = stats["median_m"]
            out[f"{prefix}_max_m"] = stats["max_m"]
            out[f"{prefix}_heading_rms_deg"] = math.degrees(stats["rms_yaw_rad"])
            out[f"{prefix}_lost_scans"] = stats["lost_scans"]
            out[f"{prefix}_scans"] = stats["scans"]
            out[f"{prefix}_odometry_only_rms_m"] = stats["odometry_only_rms_m"]
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
