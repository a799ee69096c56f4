"""Compiled inner loops: numba's ``njit`` where it is installed, plain Python otherwise.

Some of the robot's work is a loop over rays or points that numpy can only express as many
small array passes (ray casting in the simulator, the localiser's see-through trace, the scan
matcher's interpolation): each pass costs a numpy call, not arithmetic. Such a loop is written
here as plain Python over scalars and compiled with numba (Lam, Pitrou and Seibert, "Numba: a
LLVM-based Python JIT compiler", LLVM-HPC 2015).

What a kernel may rely on, and what its tests check:

- The same arithmetic. Kernels are compiled without ``fastmath`` (no reassociation, no fused
  multiply-add), so float64 operations round as CPython's and numpy's element-wise ones do, and
  ``int(x)`` truncates as ``ndarray.astype(np.intp)`` does. ``error_model="numpy"``: x / 0 is
  inf or nan, as in numpy, never an exception. A kernel's plain-Python function
  (``kernel.py_func``, or the kernel itself when numba is absent) gives the same result bit for
  bit; its tests compare the two.
- No compilation in a control loop. Each module that defines kernels registers a call with
  their real argument types (`on_warm_up`); `warm_up` runs them all, and the daemon and the
  scenario runner call it before their loop starts (the first run of a version of the sources
  compiles, in 15-20 s on two cores; later ones load numba's cache, in about a second).
- A cache that follows every source a kernel reads. numba checks a cached kernel against its
  own file only: a constant or a kernel it takes from another module (``RAY_FINE_STEP``,
  ``LETHAL``) is frozen into the compiled code. So the cache directory (numba's
  ``config.CACHE_DIR``, see `numba.core.caching`) is one per version of the kernels' sources:
  ``kernels-<hash>`` of every module that defines kernels and every project module these
  import, transitively (`kernel_sources`). Change one and the next start compiles into a new
  directory; the least recently used are removed beyond `KEEP_CACHES`. The directories live
  under `cache_root` (``$INTERBOT_KERNEL_CACHE``, systemd's ``$CACHE_DIRECTORY``, the virtual
  environment's ``var/cache/interbot``, or the user's cache directory), never in the source
  tree; where none is writable, kernels compile at each start.
- Optional. ``INTERBOT_NO_JIT=1`` in the environment, or numba not installed, leaves every kernel
  plain Python: the same results, only slower (a robot without a compiler toolchain still works).
"""

from __future__ import annotations

import hashlib
import importlib
import logging
import os
import re
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

logger = logging.getLogger(__name__)

F = TypeVar("F", bound=Callable[..., Any])

_numba: Any
try:  # pragma: no cover - which branch runs depends on the installation
    import numba as _numba
except ImportError:  # pragma: no cover
    _numba = None

#: Whether kernels are compiled in this process (numba present and not switched off).
ENABLED: bool = _numba is not None and os.environ.get("INTERBOT_NO_JIT", "") in ("", "0")

#: Cache directories (versions of the kernels' sources) kept under a root (`cache_roots`).
KEEP_CACHES = 4

_CACHE_PREFIX = "kernels-"
_KERNEL_MARK = "@jit.kernel"  # how a module that defines kernels uses this one
_PACKAGE_DIR = Path(__file__).resolve().parent  # robot_daemon/
_WARM_UPS: list[tuple[str, Callable[[], object]]] = []


# ---------------------------------------------------------------------------------- the cache
def _module_file(base: Path, name: str) -> Path | None:
    """The source file of module ``name`` (dotted) under ``base``, or None (not the project's)."""
    path = base.joinpath(*name.split("."))
    for candidate in (path.with_suffix(".py"), path / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


# An import statement anywhere in a file (functions too): ``import a.b as c, d`` or
# ``from .a import (b, c)``. A regular expression: 13-44 ms for the 27 files where `ast` took
# 110-130 ms (load 3), at every start; tests/robot_daemon/test_jit.py checks it against `ast`.
# Text that only looks like an import (in a docstring) adds a file to the hash, never drops one.
_IMPORT = re.compile(
    r"^[ \t]*(?:import[ \t]+([\w. \t,]+)|from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*))",
    re.MULTILINE,
)


def _imported_names(text: str, module: str, is_package: bool) -> Iterable[str]:
    """Every module name ``text`` imports, with its packages and, for ``from a import b``,
    ``a.b`` (a module, or a name in ``a``)."""
    package = module if is_package else module.rpartition(".")[0]
    for plain, source, imported in _IMPORT.findall(text):
        names: list[str] = []
        if plain:
            names = [item.split()[0] for item in plain.split(",") if item.strip()]
        else:
            base = source.lstrip(".")
            level = len(source) - len(base)
            if level:  # relative: from the package, one level up per extra dot
                parts = package.split(".")[: len(package.split(".")) - level + 1]
                base = ".".join([*parts, base] if base else parts)
            items = re.sub(r"#[^\n]*", "", imported).strip("() \t\n").split(",")
            names = [base, *(f"{base}.{item.split()[0]}" for item in items if item.strip())]
        for name in names:
            parts = name.split(".")
            yield from (".".join(parts[:i]) for i in range(1, len(parts) + 1))


def kernel_sources(package_dir: Path = _PACKAGE_DIR) -> list[Path]:
    """The files compiled kernels can depend on: this module, every module of the package at
    ``package_dir`` that defines kernels, and every module of the project (the packages beside
    it) that these import, transitively. Sorted."""
    base = package_dir.parent
    texts = {f: f.read_text("utf-8") for f in package_dir.rglob("*.py")}
    todo = [package_dir / "jit.py", *(f for f, text in texts.items() if _KERNEL_MARK in text)]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        relative = path.relative_to(base).with_suffix("")
        is_package = relative.name == "__init__"
        module = ".".join(relative.parent.parts if is_package else relative.parts)
        text = texts.get(path) or path.read_text("utf-8")
        for name in _imported_names(text, module, is_package):
            found = _module_file(base, name)
            if found is not None and found not in seen:
                todo.append(found)
    return sorted(seen)


def sources_key(paths: Iterable[Path], base: Path = _PACKAGE_DIR.parent) -> str:
    """A hash of the files' names (relative to ``base``) and contents: 16 hex digits."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.relative_to(base).as_posix().encode() + b"\0")
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()[:16]


def cache_roots() -> list[Path]:
    """Where the cache directories may go, best first: ``$INTERBOT_KERNEL_CACHE``, systemd's
    ``$CACHE_DIRECTORY`` (the unit's ``CacheDirectory=``; its first entry), the virtual
    environment's ``var/cache/interbot``, the user's cache directory (XDG)."""
    chosen = os.environ.get("INTERBOT_KERNEL_CACHE", "")
    systemd = os.environ.get("CACHE_DIRECTORY", "").split(":")[0]
    roots = [Path(chosen)] if chosen else []
    if systemd:
        roots.append(Path(systemd))
    if sys.prefix != sys.base_prefix:
        roots.append(Path(sys.prefix) / "var" / "cache" / "interbot")
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    roots.append(Path(xdg) / "interbot")
    return roots


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except OSError:
        return False
    return True


def _prune(root: Path, current: Path) -> None:
    """Remove the least recently used cache directories beyond `KEEP_CACHES` (``current``,
    just used, is the most recent)."""
    others = [d for d in root.glob(_CACHE_PREFIX + "*") if d.is_dir() and d != current]
    others.sort(key=lambda d: d.stat().st_mtime, reverse=True)
    for old in others[KEEP_CACHES - 1 :]:
        shutil.rmtree(old, ignore_errors=True)
        logger.info("removed the kernel cache %s (least recently used)", old)


def kernel_cache_dir() -> Path | None:
    """The cache directory of this version of the kernels' sources under the first writable
    `cache_roots` (created, marked as used now, older ones pruned); None: none is writable."""
    key = sources_key(kernel_sources())
    for root in cache_roots():
        directory = root / f"{_CACHE_PREFIX}{key}"
        if _writable(directory):
            os.utime(directory)
            _prune(root, directory)
            return directory
    logger.warning("no writable directory for compiled kernels: they compile at each start")
    return None


#: Where this process caches its kernels (None: not compiled, or nowhere writable).
CACHE_DIR: Path | None = kernel_cache_dir() if ENABLED else None


def kernel(function: F) -> F:
    """``function`` compiled (``nopython``, no GIL held, numpy's error model, cached in
    `CACHE_DIR`), or ``function`` itself when compilation is off. Compilation (or loading from
    the cache) happens at the first call."""
    if not ENABLED or _numba is None:
        return function
    options: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
    if CACHE_DIR is None:
        return _numba.njit(**options)(function)  # type: ignore[no-any-return]
    config = _numba.config
    default, config.CACHE_DIR = config.CACHE_DIR, str(CACHE_DIR)
    try:  # numba's locator for a user-provided directory reads it here, once per function
        compiled = _numba.njit(cache=True, **options)(function)
    finally:
        config.CACHE_DIR = default
    if not compiled.stats.cache_path.startswith(str(CACHE_DIR)):  # e.g. it became read-only
        logger.warning("cannot cache %s in %s: compiling at each start", function, CACHE_DIR)
        compiled = _numba.njit(**options)(function)
    return compiled  # type: ignore[no-any-return]


def python_function(function: Callable[..., Any]) -> Callable[..., Any]:
    """The plain-Python function behind a kernel (the kernel itself when not compiled)."""
    return getattr(function, "py_func", function)


def on_warm_up(name: str) -> Callable[[Callable[[], object]], Callable[[], object]]:
    """Register a call that exercises kernels with the argument types they get in use."""

    def register(call: Callable[[], object]) -> Callable[[], object]:
        _WARM_UPS.append((name, call))
        return call

    return register


def load_all() -> None:
    """Import every module of the robot that defines kernels (so `warm_up` covers them all)."""
    # the daemon imports the stack and the simulator; the runner the scenarios' metrics
    for name in ("robot_daemon.daemon", "robot_daemon.scenarios.runner"):
        importlib.import_module(name)


def warm_up() -> float:
    """Run every registered warm-up call (compiling or loading the kernels); seconds taken."""
    start = time.perf_counter()
    for name, call in _WARM_UPS:
        began = time.perf_counter()
        call()
        logger.debug("kernels of %s ready in %.3f s", name, time.perf_counter() - began)
    return time.perf_counter() - start


if __name__ == "__main__":  # `python -m robot_daemon.jit`: compile into the cache (make install)
    # The kernel modules register with the imported module, not with this __main__ copy.
    from robot_daemon import jit as _jit

    _jit.load_all()
    took = _jit.warm_up()
    print(f"robot_daemon: {len(_jit._WARM_UPS)} kernel groups ready in {took:.1f} s", end=" ")
    if not _jit.ENABLED:
        print("(plain Python: numba absent or INTERBOT_NO_JIT set)")
    else:
        print(f"(numba, cached in {_jit.CACHE_DIR or 'no writable directory'})")
