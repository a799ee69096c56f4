"""Helpers shared by the ``bench/bench_*.py`` modules: paths, percentile summaries, quiet logs.

The benchmark modules are loaded by file path (`interbot_cli.bench.load`), so ``bench/`` is not
an importable package under ``interbot bench``: each module loads this file by its path (three
lines at its top). Wall-clock timing lives only in ``bench/``, never in the libraries.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO.parent / "shared" / "data"
ISR_MAP = REPO / "maps" / "isr_floor0.yaml"
ISR_TOPO = REPO / "maps" / "isr_floor0_topo.yaml"

# The project's loggers: the scenarios log every route and recovery at INFO, which would bury
# the benchmark table. `quiet_logs` raises them to WARNING for the duration of a run.
PROJECT_LOGGERS = (
    "interbot_core",
    "interbot_link",
    "interbot_qt",
    "robot_daemon",
    "base_station_app",
)


def summary_ms(
    samples_s: Sequence[float] | np.ndarray, prefix: str, *, median_name: str = "median"
) -> dict[str, float]:
    """``{prefix}_ms_{median_name}``, ``{prefix}_ms_p99`` and ``{prefix}_ms_max`` of durations [s].

    Percentiles use numpy's linear interpolation; an empty sample gives NaN (callers report it).
    """
    a = np.asarray(samples_s, dtype=np.float64) * 1e3
    if a.size == 0:
        nan = math.nan
        return {f"{prefix}_ms_{median_name}": nan, f"{prefix}_ms_p99": nan, f"{prefix}_ms_max": nan}
    p50, p99 = (float(v) for v in np.percentile(a, [50.0, 99.0]))
    return {
        f"{prefix}_ms_{median_name}": p50,
        f"{prefix}_ms_p99": p99,
        f"{prefix}_ms_max": float(a.max()),
    }


@contextmanager
def quiet_logs(level: int = logging.WARNING) -> Iterator[None]:
    """Raise the project's loggers to ``level`` inside the block; restore them afterwards."""
    loggers = [logging.getLogger(name) for name in PROJECT_LOGGERS]
    previous = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(level)
    try:
        yield
    finally:
        for lg, old in zip(loggers, previous, strict=True):
            lg.setLevel(old)
