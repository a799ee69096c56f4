"""`interbot replay` and `interbot scenario --record` on the command line: bad input, clear errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from interbot_cli.main import build_parser, main


def test_replay_refuses_what_it_cannot_play(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", str(tmp_path / "missing.mcap")]) == 2
    assert "cannot open" in capsys.readouterr().err
    not_mcap = tmp_path / "notes.mcap"
    not_mcap.write_text("hello", encoding="utf-8")
    assert main(["replay", str(not_mcap)]) == 2
    assert "not an MCAP file" in capsys.readouterr().err
    assert main(["replay", str(not_mcap), "--speed", "50"]) == 2
    assert "outside [0.5, 20.0]" in capsys.readouterr().err
    assert main(["replay", str(not_mcap), "--listen", "udp/1.2.3.4:5"]) == 2
    assert capsys.readouterr().err.startswith("interbot replay:")


def test_scenario_takes_a_recording_file() -> None:
    args = build_parser().parse_args(["scenario", "tour", "--record", "tour.mcap"])
    assert args.record == "tour.mcap"
    assert build_parser().parse_args(["scenario", "tour"]).record is None
