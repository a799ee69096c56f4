"""Fixtures for the device tests: emulators on pseudo-terminals, cleaned up after each test."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.robot_daemon.hardware.emulators.hokuyo_emulator import HokuyoEmulator
from tests.robot_daemon.hardware.emulators.roboteq_emulator import RoboteqEmulator


def wait_until(predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Poll ``predicate`` until it holds (like pytest-qt's waitUntil); False on timeout.

    Timeouts are generous (a wait that passes costs nothing; a loaded 2-core machine starves
    these threads for hundreds of ms): what a test asserts is that a thing happens, and the
    states it waits on last until the test changes something (no transient is polled for).
    """
    deadline = time.monotonic() + timeout
    pause = threading.Event()
    while time.monotonic() < deadline:
        if predicate():
            return True
        pause.wait(0.005)
    return predicate()


_OUR_THREADS = ("hokuyo-", "roboteq-", "camera-")


@pytest.fixture(autouse=True)
def no_leaked_threads() -> Iterator[None]:
    """Every test stops the driver and emulator threads it started."""
    yield
    leaked = [t.name for t in threading.enumerate() if t.name.startswith(_OUR_THREADS)]
    assert not leaked, f"threads left running: {leaked}"


@pytest.fixture
def hokuyo(tmp_path: Path) -> Iterator[HokuyoEmulator]:
    emulator = HokuyoEmulator(link=tmp_path / "ttyACM0")
    emulator.start()
    yield emulator
    emulator.stop()


@pytest.fixture
def roboteq(tmp_path: Path) -> Iterator[RoboteqEmulator]:
    emulator = RoboteqEmulator(link=tmp_path / "ttyUSB0")
    emulator.start()
    yield emulator
    emulator.stop()


@pytest.fixture
def until() -> Callable[..., bool]:
    """`wait_until` as a fixture (test modules cannot import conftest in importlib mode)."""
    return wait_until
