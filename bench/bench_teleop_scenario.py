"""Benchmark: the reckless-driver scenario (issue 17), seed 1, with people walking.

Runs `robot_daemon.scenarios.teleop.run` headless on simulated time: scripted drivers push the
joystick at walls, through narrow doors, around corners and at people, with assisted
teleoperation + collision monitor (``assisted``), the monitor alone (``unassisted``, the station's
default) and neither (``unprotected``). Figures from the simulator's ground truth. Targets:
``teleop_collisions`` (assisted) 0, ``teleop_progress_ratio`` (assisted / unassisted) >= 0.9.
``quick`` runs one door per set-up (a smoke run).

    .venv/bin/interbot bench --only teleop_scenario --json
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

from robot_daemon.scenarios import teleop
from robot_daemon.scenarios.runner import ScenarioOptions

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SEED = 1


def run(quick: bool = False) -> dict[str, Any]:
    with common.quiet_logs():
        if quick:  # a smoke run: one door per set-up, nobody walking, 8 s at most
            options = ScenarioOptions(seed=SEED, people=0)
            result = teleop.run(options, limit=1, max_run_s=8.0)
        else:
            result = teleop.run(ScenarioOptions(seed=SEED))
    f = result.figures
    setups = f["setups"]

    def num(value: Any) -> float:
        return float("nan") if value is None else float(value)

    return {
        "teleop_runs": float(f["runs"]),
        "teleop_collisions": float(f["collisions"]),
        "teleop_collisions_unassisted": float(f["collisions_unassisted"]),
        "teleop_collisions_unprotected": float(f["collisions_unprotected"]),
        "teleop_min_clearance_m": float(f["min_clearance_m"]),
        "teleop_min_clearance_unassisted_m": float(setups["unassisted"]["min_clearance_m"]),
        "teleop_progress_m": float(f["progress_m"]),
        "teleop_progress_unassisted_m": float(setups["unassisted"]["progress_m"]),
        "teleop_progress_ratio": num(f.get("progress_ratio_vs_unassisted")),
        "teleop_progress_ratio_vs_unprotected": num(f.get("progress_ratio_vs_unprotected")),
        "teleop_time_to_doorway_s": num(f["time_to_doorway_s"]),
        "teleop_time_to_doorway_unassisted_s": num(f["time_to_doorway_unassisted_s"]),
    }


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
