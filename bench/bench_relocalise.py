"""Benchmark: the kidnap scenario (issue 16) on ISR and Willow Garage, kidnaps and cold starts.

Runs `robot_daemon.scenarios.kidnap` headless on simulated time (people walking, the runner's
default world): ``relocalise_{map}_{kidnap,cold}_*`` are the scenario's figures (kidnaps,
detected, relocalised, wrong_relocalisations, detect/relocalise times median and max, help
requests), from the simulator's ground truth. Willow Garage has no topological graph here:
targets and starts are random free poses. ``quick`` runs one ISR cold start.

    .venv/bin/interbot bench --only relocalise --json
"""

from __future__ import annotations

import importlib.util
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SEED = 1
WILLOW = common.SHARED_DATA / "maps" / "willow.yaml"
FIGURES = (
    "kidnaps",
    "detected",
    "relocalised",
    "wrong_relocalisations",
    "detect_s_median",
    "detect_s_max",
    "relocalise_s_median",
    "relocalise_s_max",
    "relocalised_within_5s",
    "relocalised_within_10s",
    "help_requests",
)


def run(quick: bool = False) -> dict[str, Any]:
    from robot_daemon.scenarios import kidnap
    from robot_daemon.scenarios.runner import ScenarioOptions

    runs = [("isr", common.ISR_MAP, True)]
    if not quick:
        runs.insert(0, ("isr", common.ISR_MAP, False))
        if WILLOW.is_file():
            runs += [("willow", WILLOW, False), ("willow", WILLOW, True)]
    out: dict[str, Any] = {}
    base = ScenarioOptions(seed=SEED)
    with common.quiet_logs():
        for name, map_yaml, cold in runs:
            options = replace(base, map_yaml=map_yaml, cold_start=cold)
            figures = kidnap.run(options, count=1 if quick else None).figures
            prefix = f"relocalise_{name}_{'cold' if cold else 'kidnap'}"
            for key in FIGURES:
                value = figures[key]
                out[f"{prefix}_{key}"] = float("nan") if value is None else float(value)
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
