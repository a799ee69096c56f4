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
- No compilation in a control loop. Compiled code is cached beside the source (or, where that is
  read-only, in numba's per-user cache) and each module that defines kernels registers a call
  with its real argument types (`on_warm_up`); `warm_up` runs them all, and the daemon and the
  scenario runner call it before their loop starts (the first run on a machine compiles, in a few
  seconds; later ones load the cache, in milliseconds).
- A known limit of numba's cache: a cached kernel is checked against its own file only. A
  constant or a kernel it takes from another module (``RAY_FINE_STEP``, ``LETHAL``) is frozen
  into the compiled code, so after changing one of those, delete the caches
  (``find robot_daemon -name '*.nb[ci]' -delete``; a fresh clone has none).
- Optional. ``INTERBOT_NO_JIT=1`` in the environment, or numba not installed, leaves every kernel
  plain Python: the same results, only slower (a robot without a compiler toolchain still works).
"""

from __future__ import annotations

import importlib
import logging
import os
import time
from collections.abc import Callable
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

_WARM_UPS: list[tuple[str, Callable[[], object]]] = []


def kernel(function: F) -> F:
    """``function`` compiled (``nopython``, no GIL held, numpy's error model, cached), or
    ``function`` itself when compilation is off. Compilation happens at the first call."""
    if not ENABLED or _numba is None:
        return function
    options: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
    try:
        compiled = _numba.njit(cache=True, **options)(function)
    except RuntimeError as exc:  # no writable cache directory anywhere: compile each start
        logger.warning("numba cannot cache %s (%s); compiling at each start", function, exc)
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
    print("(numba)" if _jit.ENABLED else "(plain Python: numba absent or INTERBOT_NO_JIT set)")
