"""`bench/bench_reallogs.py`'s odometry-noise seed: passed to both replay methods, and read
from the one-log command line (``csail --seed 2``). One seed is one draw of the replayed
odometry's noise; the CSAIL revisit is tracked with some draws and lost with others."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from interbot_cli import bench as bench_cli

BENCH = Path(__file__).resolve().parents[2] / "bench" / "bench_reallogs.py"
LOGS = BENCH.parent.parent.parent / "shared" / "data" / "laser_logs"


def test_the_seed_reaches_both_methods(monkeypatch: pytest.MonkeyPatch) -> None:
    module = bench_cli.load(BENCH)
    if not module.LOGS.is_dir():
        pytest.skip(f"{LOGS} is absent: bench_reallogs returns {{}}")
    seeds: list[tuple[str, int]] = []
    stats = {name: 1.0 for name in (*module.FIGURES, *module.DEGREE_FIGURES.values())}

    def revisits(path: Path, split: float, ms: int, ls: int, seed: int, **_: Any) -> Any:
        seeds.append(("revisit", seed))
        return stats

    def interleaved(path: Path, stride: int, seed: int, **_: Any) -> Any:
        seeds.append(("whole", seed))
        return stats

    monkeypatch.setattr(module, "localise_revisits", revisits)
    monkeypatch.setattr(module, "localise_interleaved", interleaved)
    monkeypatch.setattr(module, "read_laser_records", lambda path: [])
    out = module.run(logs=["seattle"], seed=4)
    assert seeds == [("revisit", 4), ("whole", 4)]
    assert out["reallog_seattle_revisit_rms_m"] == 1.0
    module.run(logs=["seattle"])
    assert seeds[2:] == [("revisit", 0), ("whole", 0)]  # the bench's figures: seed 0


def test_the_command_line_takes_logs_a_seed_and_a_wall_model(
    capsys: pytest.CaptureFixture[str],
) -> None:
    module = bench_cli.load(BENCH)
    args = module._arguments(["csail", "--seed", "2"])
    assert (args.logs, args.seed, args.surface) == (["csail"], 2, None)
    args = module._arguments(["--seed", "3", "intel", "aces", "--surface", "cell_face"])
    assert (args.logs, args.seed, args.surface) == (["intel", "aces"], 3, "cell_face")
    args = module._arguments([])
    assert (args.logs, args.seed, args.surface) == ([], 0, None)
    bad = {
        ("csail", "--seed"): "--seed: expected one argument",
        ("csail", "--seed", "two"): "--seed: invalid int value: 'two'",
        ("--help-me",): "unrecognized arguments: --help-me",
        ("csail", "nowhere"): "unknown log(s) nowhere: choose from",
        ("--surface", "glass"): "--surface: invalid choice: 'glass'",
    }
    for argv, message in bad.items():
        with pytest.raises(SystemExit) as exit_:
            module._arguments(list(argv))
        assert exit_.value.code == 2  # argparse's usage error, not a traceback
        assert message in capsys.readouterr().err
