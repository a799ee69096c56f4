"""Test-wide setup: offscreen Qt, and the location of the real data shared beside the repo."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

# Before any QApplication exists (pytest-qt creates it lazily).
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO_ROOT = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels() -> None:
    """Every compiled kernel compiled (a first run, or after its source changed) or loaded from
    numba's cache once, before any test (`robot_daemon.jit`). A daemon a test starts as a
    subprocess warms its kernels up before it serves; compiling them all there took 13-17 s on
    the 2-core machine, longer than such tests wait for a daemon to come up."""
    from robot_daemon import jit

    jit.load_all()
    jit.warm_up()


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """../shared/data (real maps and laser logs); tests skip with a reason where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found at {SHARED_DATA} (see shared/data/README.md)")
    return SHARED_DATA


def _free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 the OS handed out, held for the caller's server (tests/ports.py)."""
    from tests.ports import reserve_port

    return reserve_port()


@pytest.fixture
def free_tcp_port() -> Callable[[], int]:
    return _free_tcp_port


def _wait_until(predicate: Callable[[], bool], timeout: float = 5.0, what: str = "") -> None:
    """Poll ``predicate`` every 5 ms until true; fail with ``what`` after ``timeout`` [s]."""
    import time

    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what or predicate}")
        time.sleep(0.005)


@pytest.fixture
def wait_until() -> Callable[..., None]:
    return _wait_until


def _query_state(station: Any, robot_id: str, timeout: float = 5.0) -> dict[Any, object]:
    """A robot's state snapshot through the station's own path: `StationLink.request_state`,
    then the parts that arrive together as events (one reply, decoded in one poll)."""
    from interbot_link import StateMessage

    station.request_state(robot_id)
    found: dict[Any, object] = {}

    def arrived() -> bool:
        for event in station.poll_events():
            if isinstance(event, StateMessage) and event.robot_id == robot_id:
                found[event.topic] = event.message
        return bool(found)

    _wait_until(arrived, timeout, f"the state of {robot_id}")
    return found


@pytest.fixture
def query_state() -> Callable[..., dict[Any, object]]:
    return _query_state
