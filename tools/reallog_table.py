"""The README's real-log table, printed from the output of ``interbot bench --only reallogs --json``.

The bench prints its figures as one JSON object on its last line (``reallog_<log>_<method>_<figure>``,
`bench/bench_reallogs.py` says what each figure is). This tool turns that line into the Markdown
table the README shows, one row per log and method, so the table is the measurement and nothing
is copied by hand::

    .venv/bin/interbot bench --only reallogs --json | tail -1 > /tmp/reallogs.json
    .venv/bin/python tools/reallog_table.py /tmp/reallogs.json

A log and method the bench did not evaluate (a log that does not revisit has no revisit scans)
gets a row that says so. Input that is not the bench's JSON is refused with a message naming
what is wrong; nothing is printed then. Not shipped with the robot.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Mapping
from pathlib import Path

# The bench's logs in its order (`bench_reallogs.CASES`) and the names a reader knows them by.
LOGS: dict[str, str] = {
    "intel": "Intel Research Lab",
    "freiburg079": "Freiburg 079",
    "aces": "ACES (Austin)",
    "csail": "MIT CSAIL",
    "freiburg_campus": "Freiburg campus",
    "infinite_corridor": "MIT Infinite Corridor",
    "orebro": "Örebro",
    "seattle": "Seattle (UW)",
}
METHODS = ("revisit", "whole")

HEADER = (
    "| log | method | scans | RMS / median / max cm | RMS over ok scans cm | heading RMS ° "
    "| reference's own offset cm / ° | lost / degraded scans | silent failures (seeds) "
    "| ms per scan median / p99 (p99 tracking) | CPU ms per scan median / p99 (p99 tracking) |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|"
)


class TableError(ValueError):
    """The input is not what ``interbot bench --only reallogs --json`` prints."""


def load(text: str) -> dict[str, float]:
    """The bench's figures from its JSON line (the last non-empty line of ``text``)."""
    lines = [line for line in text.splitlines() if line.strip()]
    if not lines:
        raise TableError(
            "empty input: expected the JSON line of `interbot bench --only reallogs --json`"
        )
    try:
        figures = json.loads(lines[-1])
    except json.JSONDecodeError as exc:
        raise TableError(f"the last line is not JSON ({exc.msg} at column {exc.colno})") from None
    if not isinstance(figures, dict):
        raise TableError(f"expected a JSON object of figures, got {type(figures).__name__}")
    out: dict[str, float] = {}
    for key, value in figures.items():
        if not key.startswith("reallog_"):
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise TableError(f"figure {key!r} is {value!r}, not a finite number")
        out[key] = float(value)
    if not out:
        raise TableError("no reallog_* figures: was it `interbot bench --only reallogs --json`?")
    return out


def rows(figures: Mapping[str, float]) -> list[str]:
    """One Markdown row per log and method, in the bench's order."""
    table = []
    for log, name in LOGS.items():
        for method in METHODS:
            table.append(_row(figures, log, method, name))
    return table


def _row(figures: Mapping[str, float], log: str, method: str, name: str) -> str:
    def get(figure: str) -> float | None:
        return figures.get(f"reallog_{log}_{method}_{figure}")

    scans = get("scans")
    if not scans:
        return f"| {name} | {method} | 0 | not evaluated (no {method} run) | | | | | | | |"
    cm = _fmt(100.0, 2)
    cells = [
        name,
        method,
        f"{scans:.0f}",
        f"{cm(get('rms_m'))} / {cm(get('median_m'))} / {_fmt(100.0, 1)(get('max_m'))}",
        f"{cm(get('ok_rms_m'))}",
        f"{_fmt(1.0, 2)(get('heading_rms_deg'))}",
        f"{cm(get('reference_offset_rms_m'))} / {_fmt(1.0, 2)(get('reference_heading_offset_rms_deg'))}",
        f"{_fmt(1.0, 0)(get('lost_scans'))} / {_fmt(1.0, 0)(get('degraded_scans'))}",
        f"{_fmt(1.0, 0)(get('silent_failures'))} ({_fmt(1.0, 0)(get('silent_failures_seeds'))})",
        _ms(get, ""),
        _ms(get, "cpu_"),
    ]
    return "| " + " | ".join(cells) + " |"


def _ms(get: Callable[[str], float | None], kind: str) -> str:
    """The cell of the localiser's time per scan: wall clock (``kind`` "") or the process's CPU
    time (``kind`` "cpu_", which a shared machine's pre-emption does not inflate)."""
    ms = _fmt(1.0, 2)
    return (
        f"{ms(get(kind + 'ms_median'))} / {ms(get(kind + 'ms_p99'))} "
        f"({ms(get(kind + 'ms_p99_tracking'))})"
    )


def _fmt(scale: float, digits: int) -> Callable[[float | None], str]:
    """A formatter of a figure times ``scale`` with ``digits`` decimals; a missing one is a dash."""

    def fmt(value: float | None) -> str:
        return "–" if value is None else f"{value * scale:.{digits}f}"

    return fmt


def summary(figures: Mapping[str, float]) -> str:
    """The line under the table: silent failures over every log, method and seed."""
    total = figures.get("reallog_all_silent_failures")
    seeds = figures.get("reallog_seeds")
    if total is None or seeds is None:
        return "Silent failures over every log and method: not in this output."
    return (
        f"Silent failures over every log, method and {seeds:.0f} odometry seeds: **{total:.0f}**."
    )


def consistency(figures: Mapping[str, float]) -> str:
    """The lines on the logged poses themselves (``reallog_<log>_reference_consistency_*`` and
    ``_reference_pass_consistency_*``, `bench/bench_reallogs.py`): each against its own scan
    fitted to the two scans logged before it, and to the two nearest of the first half (the
    revisit's map); empty when the output has neither."""
    lines = []
    for figure, what in (
        (
            "reference_consistency",
            "The logged poses against their own scans (each scan fitted by point-to-line ICP "
            "to the two logged just before it, both within 0.5 m; exact poses: 0.3 cm / 0.05°)",
        ),
        (
            "reference_pass_consistency",
            "Between passes (each scan of the second half fitted to the two first-half scans "
            "nearest it, within 0.5 m and 45°, whose logged poses built the revisit's map)",
        ),
    ):
        cells = []
        for log, name in LOGS.items():
            metres = figures.get(f"reallog_{log}_{figure}_rms_m")
            degrees = figures.get(f"reallog_{log}_{figure}_rms_deg")
            scans = figures.get(f"reallog_{log}_{figure}_scans")
            if metres is not None and degrees is not None and scans is not None:
                cells.append(f"{name} {metres * 100:.2f} cm / {degrees:.2f}° ({scans:.0f} scans)")
        if cells:
            lines.append(f"{what}: " + ", ".join(cells) + ".")
    return "\n\n".join(lines)


def seen(figures: Mapping[str, float]) -> str:
    """The line on the scans whose view the map holds (``reallog_<log>_<method>_seen_*``,
    `bench/bench_reallogs.py`): the RMS over them where some scans of a log and method look
    where the map was never made; empty where every scan's view is mapped or the output has
    no such figures."""
    cells = []
    for log, name in LOGS.items():
        for method in METHODS:
            key = f"reallog_{log}_{method}_"
            scans, seen_scans = figures.get(key + "scans"), figures.get(key + "seen_scans")
            if scans and seen_scans is not None and seen_scans < scans:
                cm = _fmt(100.0, 2)
                cells.append(
                    f"{name} {method} {cm(figures.get(key + 'seen_rms_m'))} cm over "
                    f"{seen_scans:.0f} of {scans:.0f} scans (all: {cm(figures.get(key + 'rms_m'))} cm)"
                )
    if not cells:
        return ""
    return (
        "Over the scans whose view the map holds (at least 35 % of the end points, at the "
        "logged pose, on cells the map observed; every other log and method: all scans): "
        + ", ".join(cells)
        + "."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json_file", nargs="?", help="the bench's output (default: standard input)")
    args = parser.parse_args(argv)
    try:
        text = (
            Path(args.json_file).read_text(encoding="utf-8") if args.json_file else sys.stdin.read()
        )
        figures = load(text)
    except (OSError, UnicodeDecodeError, TableError) as exc:
        print(f"reallog_table: {exc}", file=sys.stderr)
        return 2
    print(HEADER)
    print("\n".join(rows(figures)))
    print()
    print(summary(figures))
    for line in (seen(figures), consistency(figures)):
        if line:
            print()
            print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
