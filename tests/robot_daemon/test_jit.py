"""The compiled-kernel wrapper (`robot_daemon/jit.py`): compiled and plain Python agree, and
the switch and the warm-up registry do what they say, and the cache follows every source a
kernel reads."""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from robot_daemon import jit

PROJECT = Path(jit.__file__).resolve().parent.parent


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


# ------------------------------------------------------------------------------- the cache
def test_the_cache_key_covers_the_modules_kernels_take_constants_from() -> None:
    sources = {p.relative_to(PROJECT).as_posix() for p in jit.kernel_sources()}
    assert "robot_daemon/sim/world.py" in sources  # RAY_FINE_STEP (sim/sphere_tracing.py)
    assert "robot_daemon/planning/costmap.py" in sources  # LETHAL (planning/global_planner.py)
    assert "robot_daemon/jit.py" in sources  # the compiler's options
    # what no kernel imports does not recompile them all when it changes
    assert "robot_daemon/daemon.py" not in sources


def _ast_imports(tree: ast.Module, module: str, is_package: bool) -> set[str]:
    """The reference: every module an `ast` says the file imports (with their packages and the
    ``a.b`` of ``from a import b``), as `jit._imported_names` reads them from the text."""
    package = module if is_package else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            found = [base, *(f"{base}.{alias.name}" for alias in node.names)]
        else:
            continue
        for name in found:
            parts = name.split(".")
            names |= {".".join(parts[:i]) for i in range(1, len(parts) + 1)}
    return names


def test_the_import_scan_finds_every_import_an_ast_finds() -> None:
    """The regular expression may see more (text in a docstring), never less."""
    for path in sorted(
        [
            *PROJECT.joinpath("robot_daemon").rglob("*.py"),
            *PROJECT.joinpath("interbot_core").rglob("*.py"),
        ]
    ):
        relative = path.relative_to(PROJECT).with_suffix("")
        is_package = relative.name == "__init__"
        module = ".".join(relative.parent.parts if is_package else relative.parts)
        text = path.read_text("utf-8")
        expected = _ast_imports(ast.parse(text), module, is_package)
        assert expected <= set(jit._imported_names(text, module, is_package)), path


def test_old_cache_directories_are_pruned_least_recently_used_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("INTERBOT_KERNEL_CACHE", str(tmp_path))
    ages = range(1, 8)  # [days]
    for age in ages:
        old = tmp_path / f"kernels-old{age}"
        (old / "sub").mkdir(parents=True)
        stamp = time.time() - age * 86400
        os.utime(old, (stamp, stamp))
    (tmp_path / "unrelated").mkdir()
    current = jit.kernel_cache_dir()
    assert current is not None and current.parent == tmp_path and current.is_dir()
    kept = sorted(d.name for d in tmp_path.glob("kernels-*"))
    newest = [f"kernels-old{age}" for age in ages[: jit.KEEP_CACHES - 1]]
    assert kept == sorted([current.name, *newest])
    assert (tmp_path / "unrelated").is_dir()


_PROBE = """\
from robot_daemon import jit
from robot_daemon.sim.world import RAY_FINE_STEP


@jit.kernel
def scaled(x: float) -> float:
    return x * RAY_FINE_STEP
"""

# Run in a copy of the project: the editable install's finder would import the work tree.
_RUN_PROBE = """\
import json, sys
sys.meta_path[:] = [f for f in sys.meta_path if not type(f).__module__.startswith("__editable")]
sys.path.insert(0, sys.argv[1])
from robot_daemon import jit, probe_kernel
stats = probe_kernel.scaled.stats
print(json.dumps({
    "jit": jit.__file__, "cache": str(getattr(jit, "CACHE_DIR", None)), "value": probe_kernel.scaled(2.0),
    "plain": jit.python_function(probe_kernel.scaled)(2.0),
    "hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
}))
"""


@pytest.mark.skipif(not jit.ENABLED, reason="kernels are plain Python here (nothing cached)")
def test_a_kernel_follows_a_changed_constant_of_another_module_and_loads_unchanged_ones(
    tmp_path: Path,
) -> None:
    """numba alone checks a cached kernel against its own file: the constant it imports from
    sim/world.py stayed frozen (this test failed on the session-13 code at the third run)."""
    copy = tmp_path / "src"
    ignore = shutil.ignore_patterns("__pycache__")
    for package in ("robot_daemon", "interbot_core"):
        shutil.copytree(PROJECT / package, copy / package, ignore=ignore)
    (copy / "robot_daemon" / "probe_kernel.py").write_text(_PROBE)
    env = {**os.environ, "INTERBOT_KERNEL_CACHE": str(tmp_path / "cache")}

    def run() -> dict[str, object]:
        command = [sys.executable, "-c", _RUN_PROBE, str(copy)]
        out = subprocess.run(command, env=env, cwd=tmp_path, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        result: dict[str, object] = json.loads(out.stdout)
        assert str(result["jit"]).startswith(str(copy)), result  # the copy, not the work tree
        return result

    first = run()
    assert first["value"] == first["plain"] == 1.0 and first["misses"] == 1
    again = run()  # nothing changed: loaded from the cache, not compiled
    assert again["value"] == 1.0 and (again["hits"], again["misses"]) == (1, 0)
    assert again["cache"] == first["cache"]
    world = copy / "robot_daemon" / "sim" / "world.py"
    text = world.read_text()
    assert "RAY_FINE_STEP = 0.5" in text
    world.write_text(text.replace("RAY_FINE_STEP = 0.5", "RAY_FINE_STEP = 0.25"))
    changed = run()
    assert changed["value"] == changed["plain"] == 0.5  # compiled anew, not the frozen 0.5 cells
    assert changed["misses"] == 1 and changed["cache"] != first["cache"]
