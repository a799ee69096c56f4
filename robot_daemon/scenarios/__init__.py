"""Headless runs of the thesis's test scenarios on simulated time (``interbot scenario``)."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

from robot_daemon.config import DEFAULT_MAP, DEFAULT_TOPO
from robot_daemon.scenarios.runner import ScenarioOptions, ScenarioResult

SCENARIOS = ("odometry", "tour", "mission", "latency", "kidnap", "teleop")


def load_scenario(name: str) -> Callable[[ScenarioOptions], ScenarioResult]:
    """The ``run`` function of scenario ``name`` (imported on demand)."""
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; choose one of {', '.join(SCENARIOS)}")
    module = importlib.import_module(f"robot_daemon.scenarios.{name}")
    run: Callable[[ScenarioOptions], ScenarioResult] = module.run
    return run


def main(args: argparse.Namespace) -> int:
    """Run ``args.name`` and print its table; with ``--json`` the last line is the figures."""
    try:
        run = load_scenario(args.name)
    except ValueError as exc:
        print(f"interbot scenario: {exc}", file=sys.stderr)
        return 2
    options = ScenarioOptions(
        map_yaml=Path(args.map_yaml) if args.map_yaml else DEFAULT_MAP,
        topo_yaml=Path(args.topo) if args.topo else DEFAULT_TOPO,
        seed=args.seed,
        ideal_world=bool(getattr(args, "ideal_world", False)),
        cold_start=bool(getattr(args, "cold_start", False)),
        idle_after_kidnap=bool(getattr(args, "idle_after_kidnap", False)),
        idle_at_power_on=bool(getattr(args, "idle_at_power_on", False)),
    )
    if getattr(args, "record", None):
        from dataclasses import replace

        from robot_daemon.recording.scenario_recording import ScenarioRecorder

        with ScenarioRecorder(Path(args.record), epoch_offset=time.time()) as recorder:
            result = run(replace(options, recorder=recorder))
        print(f"recorded to {args.record}: {recorder.recorder.stats()['written']} messages")
    else:
        result = run(options)
    print(result.table)
    if args.json:
        print(json.dumps(result.figures, sort_keys=True))
    return 0
