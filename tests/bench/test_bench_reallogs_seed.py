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


def test_the_command_line_takes_logs_and_a_seed() -> None:
    module = bench_cli.load(BENCH)
    assert module._arguments(["csail", "--seed", "2"]) == (["csail"], 2)
    assert module._arguments(["--seed", "3", "intel", "aces"]) == (["intel", "aces"], 3)
    assert module._arguments([]) == ([], 0)
    with pytest.raises(SystemExit, match="--seed needs an integer"):
        module._arguments(["csail", "--seed"])
    with pytest.raises(SystemExit, match="--seed needs an integer"):
        module._arguments(["csail", "--seed", "two"])
