"""tools/reallog_table.py: the README's real-log table from the bench's JSON, and what it refuses."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[2]


def _load() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "reallog_table", REPO / "tools" / "reallog_table.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


table = _load()


def _figures() -> dict[str, float]:
    intel = {
        "scans": 172.0,
        "rms_m": 0.0281,
        "median_m": 0.0172,
        "max_m": 0.1034,
        "ok_rms_m": 0.029,
        "heading_rms_deg": 0.469,
        "reference_offset_rms_m": 0.066,
        "reference_heading_offset_rms_deg": 0.351,
        "lost_scans": 0.0,
        "degraded_scans": 23.0,
        "silent_failures": 0.0,
        "silent_failures_seeds": 1.0,
        "ms_median": 0.831,
        "ms_p99": 1.386,
        "ms_p99_tracking": 1.2,
        "cpu_ms_median": 0.802,
        "cpu_ms_p99": 1.1,
        "cpu_ms_p99_tracking": 1.05,
    }
    figures = {f"reallog_intel_revisit_{k}": v for k, v in intel.items()}
    figures["reallog_aces_revisit_scans"] = 0.0  # a log that does not revisit
    figures["reallog_all_silent_failures"] = 1.0
    figures["reallog_seeds"] = 3.0
    return figures


def test_a_row_carries_every_figure_in_the_units_of_the_header() -> None:
    row = next(r for r in table.rows(_figures()) if r.startswith("| Intel Research Lab | revisit"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells == [
        "Intel Research Lab",
        "revisit",
        "172",
        "2.81 / 1.72 / 10.3",
        "2.90",
        "0.47",
        "6.60 / 0.35",
        "0 / 23",
        "0 (1)",
        "0.83 / 1.39 (1.20)",
        "0.80 / 1.10 (1.05)",
    ]
    assert len(cells) == table.HEADER.splitlines()[0].count("|") - 1


def test_every_log_and_method_has_a_row_and_missing_runs_say_so() -> None:
    rows = table.rows(_figures())
    assert len(rows) == 2 * len(table.LOGS)
    aces = next(r for r in rows if r.startswith("| ACES (Austin) | revisit"))
    assert "not evaluated" in aces
    seattle = next(r for r in rows if r.startswith("| Seattle (UW) | whole"))
    assert "not evaluated" in seattle


def test_the_summary_counts_silent_failures_over_the_seeds() -> None:
    assert table.summary(_figures()) == (
        "Silent failures over every log, method and 3 odometry seeds: **1**."
    )


def test_the_reference_consistency_line_names_the_logs_checked() -> None:
    figures = _figures() | {
        "reallog_freiburg079_reference_consistency_rms_m": 0.0283,
        "reallog_freiburg079_reference_consistency_rms_deg": 0.604,
        "reallog_freiburg079_reference_consistency_scans": 320.0,
        "reallog_seattle_reference_consistency_scans": 0.0,  # none could be checked
    }
    figures |= {
        "reallog_freiburg079_reference_pass_consistency_rms_m": 0.0435,
        "reallog_freiburg079_reference_pass_consistency_rms_deg": 0.48,
        "reallog_freiburg079_reference_pass_consistency_scans": 61.0,
    }
    own, passes = table.consistency(figures).split("\n\n")
    assert own.startswith("The logged poses against their own scans")
    assert "Freiburg 079 2.83 cm / 0.60° (320 scans)" in own
    assert "Seattle" not in own
    assert passes.startswith("Between passes")
    assert "Freiburg 079 4.35 cm / 0.48° (61 scans)" in passes
    assert table.consistency(_figures()) == ""


def test_the_seen_line_names_only_runs_with_scans_whose_view_is_not_mapped() -> None:
    """A log and method whose every scan sees its map (Intel revisit here) is not named; one
    with scans that look where the map was never made gets the RMS over the others beside the
    RMS over all (`bench_reallogs.SEEN_FIGURES`)."""
    figures = _figures() | {"reallog_intel_revisit_seen_scans": 172.0}
    figures |= {
        "reallog_freiburg_campus_revisit_scans": 238.0,
        "reallog_freiburg_campus_revisit_rms_m": 0.0581,
        "reallog_freiburg_campus_revisit_seen_scans": 221.0,
        "reallog_freiburg_campus_revisit_seen_rms_m": 0.0424,
    }
    line = table.seen(figures)
    assert line.startswith("Over the scans whose view the map holds")
    assert "Freiburg campus revisit 4.24 cm over 221 of 238 scans (all: 5.81 cm)" in line
    assert "Intel" not in line
    assert table.seen(_figures()) == ""


def test_main_reads_the_last_line_of_the_bench_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench.out"
    out.write_text(
        "== bench_reallogs.py (137.0 s)\n  reallog_intel ...\n" + json.dumps(_figures()) + "\n"
    )
    assert table.main([str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(table.HEADER)
    assert "| Intel Research Lab | revisit | 172 |" in printed


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty input"),
        ("not json\n", "not JSON"),
        ("[1, 2]\n", "JSON object"),
        ('{"reallog_intel_revisit_rms_m": "x"}\n', "not a finite number"),
        ('{"reallog_intel_revisit_rms_m": NaN}\n', "not a finite number"),
        ('{"teleop_p99_ms": 2.0}\n', "no reallog_* figures"),
    ],
)
def test_bad_input_is_refused_with_a_reason_and_prints_no_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    assert table.main([str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert message in captured.err
