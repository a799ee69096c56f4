"""The compiled-kernel wrapper (`robot_daemon/jit.py`): compiled and plain Python agree, and
the switch and the warm-up registry do what they say."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from robot_daemon import jit


@jit.kernel
def _march(start: float, steps: np.ndarray, scale: float) -> float:
    # float arithmetic a compiler could reorder or fuse (a * b + c) if allowed to
    t = start
    for s in steps:
        t = t * scale + s / 3.0
        if int(t) > 1_000_000:
            t -= 1_000_000.0
    return t


def test_compiled_and_plain_python_agree_bit_for_bit() -> None:
    rng = np.random.default_rng(1)
    steps = rng.normal(0.0, 10.0, 500)
    compiled = _march(0.1, steps, 1.0000001)
    plain = jit.python_function(_march)(0.1, steps, 1.0000001)
    assert compiled == plain  # exact: no fastmath, no fused multiply-add


def test_division_by_zero_follows_numpy_not_an_exception() -> None:
    @jit.kernel
    def ratio(a: float, b: float) -> float:
        return a / b

    assert ratio(1.0, 0.0) == np.inf or not jit.ENABLED


def test_warm_up_runs_registered_calls() -> None:
    calls: list[int] = []
    jit.on_warm_up("test")(lambda: calls.append(1))
    try:
        assert jit.warm_up() >= 0.0
        assert calls == [1]
    finally:
        jit._WARM_UPS.pop()


def test_switched_off_by_the_environment() -> None:
    code = "from robot_daemon import jit; print(jit.ENABLED)"
    env = {**os.environ, "INTERBOT_NO_JIT": "1"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == "False", out.stderr
