"""bench/_teleop_tablet.py and bench_teleop's sample count: every command of a run of any length
reaches the multiplexer unchanged (distinct, under the mux's tablet limit), and a bad
``TELEOP_SAMPLES`` is refused by name. (Issue 14: a 1,200-sample run "hung": its commands from
the 451st on exceeded the mux's 1 rad/s and were scaled down, so each timed out, and the
tablet process then blocked writing its result to a full pipe.)"""

from __future__ import annotations

import importlib.util
import itertools
import re
from pathlib import Path
from types import ModuleType

import pytest

from interbot_core.velocity_mux import load_mux_config

BENCH_DIR = Path(__file__).resolve().parents[2] / "bench"
MUX_YAML = BENCH_DIR.parent / "resources" / "config" / "interbot_mux.yaml"


def load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"bench_test_{name}", BENCH_DIR / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def tablet() -> ModuleType:
    return load("_teleop_tablet")


@pytest.mark.parametrize("n", [20, 300, 1200, 5000])
def test_every_command_is_distinct_and_under_the_tablet_limit(tablet: ModuleType, n: int) -> None:
    values = [tablet.speed_value(i, n) for i in range(n)]
    assert len(set(values)) == n  # each sample is told apart by its value
    limit = load_mux_config(MUX_YAML).input_by_topic("tablet_vel").max_angular
    assert all(lin == 0.0 and 0.1 - 1e-9 <= abs(ang) <= 0.7 + 1e-9 < limit for lin, ang in values)
    assert all(a[1] * b[1] < 0 for a, b in itertools.pairwise(values))  # alternate
    # Neighbours differ by far more than the observer's 1e-6 match and float32 rounding.
    magnitudes = sorted(abs(v[1]) for v in values)
    assert min(b - a for a, b in itertools.pairwise(magnitudes)) > 1e-4


def test_the_300_sample_run_keeps_its_commands(tablet: ModuleType) -> None:
    """The figures of earlier sessions came from these exact commands (2 mrad/s steps)."""
    assert [tablet.speed_value(i, 300) for i in (0, 1, 299)] == [(0.0, 0.1), (0.0, -0.102), (0.0, -0.698)]  # fmt: skip


def test_an_index_outside_the_run_is_refused(tablet: ModuleType) -> None:
    with pytest.raises(ValueError, match=re.escape("sample index 300 outside 0..299")):
        tablet.speed_value(300, 300)


@pytest.mark.parametrize("text", ["0", "-5", "5001", "many", "1.5", ""])
def test_a_bad_sample_count_is_refused_by_name(text: str, monkeypatch: pytest.MonkeyPatch) -> None:
    teleop = load("bench_teleop")
    monkeypatch.setenv("TELEOP_SAMPLES", text)
    with pytest.raises(teleop.BenchTeleopError, match=re.escape(f"TELEOP_SAMPLES={text!r}")):
        teleop.samples_from_env()


def test_the_sample_count_defaults_to_300(monkeypatch: pytest.MonkeyPatch) -> None:
    teleop = load("bench_teleop")
    monkeypatch.delenv("TELEOP_SAMPLES", raising=False)
    assert teleop.samples_from_env() == 300
    monkeypatch.setenv("TELEOP_SAMPLES", "1200")
    assert teleop.samples_from_env() == 1200
