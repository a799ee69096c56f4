"""`interbot bench --secure` reaches benchmarks that support it and refuses the others."""

from __future__ import annotations

import time
import types

import pytest

from interbot_cli import bench


def _module(source: str) -> types.ModuleType:
    module = types.ModuleType("bench_fake")
    exec(source, module.__dict__)  # a tiny stand-in for a bench_*.py file
    return module


def test_secure_is_passed_only_to_benchmarks_that_take_it() -> None:
    both = _module("def run(quick=False, secure=False):\n    return {'secure': float(secure)}\n")
    assert bench.call_run(both, quick=True, secure=True) == {"secure": 1.0}
    assert bench.call_run(both, quick=True) == {"secure": 0.0}
    plain = _module("def run(quick=False):\n    return {'x': 1.0}\n")
    with pytest.raises(bench.BenchError, match="no secure variant"):
        bench.call_run(plain, quick=True, secure=True)


def test_the_teleop_benchmark_has_a_secure_variant() -> None:
    module = bench.load(bench.BENCH_DIR / "bench_teleop.py")
    assert "secure" in module.run.__code__.co_varnames


def test_busy_core_is_passed_only_to_benchmarks_that_take_it() -> None:
    both = _module("def run(quick=False, busy_core=False):\n    return {'b': float(busy_core)}\n")
    assert bench.call_run(both, quick=True, busy_core=True) == {"b": 1.0}
    plain = _module("def run(quick=False, secure=False):\n    return {'x': 1.0}\n")
    with pytest.raises(bench.BenchError, match="no busy_core variant"):
        bench.call_run(plain, quick=True, busy_core=True)


def test_the_busy_core_process_spins_and_is_ended() -> None:
    module = bench.load(bench.BENCH_DIR / "bench_teleop.py")
    assert "busy_core" in module.run.__code__.co_varnames
    with module.busy_process(False) as none:
        assert none is None
    with module.busy_process(True) as spin:
        time.sleep(0.3)
        assert spin.poll() is None  # still spinning
    assert spin.returncode is not None  # ended with the measurement
