"""`interbot bench`: run every ``bench/bench_*.py`` module's ``run()`` and report the figures.

Each benchmark module exposes ``run(quick: bool = False) -> dict[str, float]`` (wall-clock
timing lives only in bench/, never in the libraries). The figures are printed as a table; with
``--json`` the last line is one JSON object merging all of them (medians and p99 in ms).
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import json
import math
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

BENCH_DIR = Path(__file__).resolve().parent.parent / "bench"


class BenchError(RuntimeError):
    """A benchmark could not be found or failed."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="last line: one JSON object")
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (smoke run)")
    parser.add_argument("--only", action="append", default=[], help="run only bench_NAME.py")
    parser.add_argument(
        "--secure",
        action="store_true",
        help="links with mutual TLS, access control and a paired TLS tablet (benchmarks that "
        "support it, e.g. teleop)",
    )
    parser.add_argument(
        "--busy-core",
        action="store_true",
        help="keep one core busy in another process while measuring (benchmarks that support "
        "it, e.g. teleop)",
    )


def discover(only: list[str]) -> list[Path]:
    if not BENCH_DIR.is_dir():
        raise BenchError(f"no benchmark folder at {BENCH_DIR}")
    paths = sorted(BENCH_DIR.glob("bench_*.py"))
    if only:
        wanted = {name.removeprefix("bench_").removesuffix(".py") for name in only}
        paths = [p for p in paths if p.stem.removeprefix("bench_") in wanted]
        missing = wanted - {p.stem.removeprefix("bench_") for p in paths}
        if missing:
            raise BenchError(f"unknown benchmark(s): {', '.join(sorted(missing))}")
    return paths


def load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"interbot_bench_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise BenchError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not callable(getattr(module, "run", None)):
        raise BenchError(f"{path.name} has no run() function")
    return module


def call_run(
    module: ModuleType, quick: bool, secure: bool = False, busy_core: bool = False
) -> dict[str, Any]:
    params = inspect.signature(module.run).parameters
    kwargs: dict[str, bool] = {"quick": quick} if "quick" in params else {}
    for name, wanted, flag in (("secure", secure, "--secure"), ("busy_core", busy_core, "--busy-core")):  # fmt: skip
        if wanted:
            if name not in params:
                raise BenchError(f"{module.__name__} has no {name} variant ({flag})")
            kwargs[name] = True
    result = module.run(**kwargs)
    if not isinstance(result, dict):
        raise BenchError(f"{module.__name__}.run() returned {type(result).__name__}, not dict")
    return result


def format_value(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3f}" if math.isfinite(value) else str(value)
    return str(value)


def run(args: argparse.Namespace) -> int:
    figures: dict[str, Any] = {}
    paths = discover(args.only)
    if not paths:
        raise BenchError(f"no bench_*.py modules in {BENCH_DIR}")
    from robot_daemon import jit

    jit.load_all()  # every kernel compiled or loaded before any clock runs, as the daemon does
    jit.warm_up()
    for path in paths:
        started = time.perf_counter()
        result = call_run(
            load(path),
            args.quick,
            getattr(args, "secure", False),
            getattr(args, "busy_core", False),
        )
        elapsed = time.perf_counter() - started
        print(f"== {path.name} ({elapsed:.1f} s)")
        for key, value in result.items():
            print(f"  {key:<32} {format_value(value)}")
        figures.update(result)
    if args.json:
        print(json.dumps(figures, sort_keys=True))
    sys.stdout.flush()
    return 0
