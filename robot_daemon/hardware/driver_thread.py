"""The worker thread of a device driver (the laser, the motor controller, the camera).

Each driver talks to its device in one daemon thread and shares results under ``_lock``:
`start` starts the thread, `close` asks it to stop (``_stop``), wakes it and joins it (logging
a thread that did not stop in time). ``close`` is idempotent; the thread releases its device on
the way out (the laser sends QT/RS, the motor controller zero on both channels). Each driver
also keeps, under the same lock, whether its device is connected, why not (``_message``) and
its ``counters``, which its ``status`` reports.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable
from typing import Self

logger = logging.getLogger(__name__)


class DriverThread:
    """Start/stop of a driver's thread, which runs ``_run`` until ``_stop`` is set."""

    THREAD_NAME = "driver"

    def __init__(self, label: str, counters: Iterable[str]) -> None:
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.label = label  # names the device in log lines: "laser /dev/ttyACM0"
        self.counters: dict[str, int] = dict.fromkeys(counters, 0)
        self._connected = False
        self._message = "not started"

    def start(self) -> Self:
        self._thread = threading.Thread(target=self._run, name=self.THREAD_NAME, daemon=True)
        self._thread.start()
        return self

    def close(self, timeout: float = 3.0) -> None:
        self._stop.set()
        self._wake_up()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                logger.error("%s thread did not stop within %.1f s", self.THREAD_NAME, timeout)
            self._thread = None

    def _count(self, key: str, n: int = 1) -> None:
        with self._lock:
            self.counters[key] += n

    def _set_state(self, connected: bool, message: str) -> None:
        with self._lock:
            self._connected = connected
            self._message = message

    def _fail(self, message: str) -> None:
        """Not connected, and why: a warning when the reason changes, repeats at debug level."""
        with self._lock:
            repeated = message == self._message
        if not self._stop.is_set():
            logger.log(
                logging.DEBUG if repeated else logging.WARNING, "%s: %s", self.label, message
            )
        self._set_state(False, message)

    def _wake_up(self) -> None:
        """Interrupt a wait on something other than ``_stop`` (overridden where there is one)."""

    def _run(self) -> None:
        raise NotImplementedError
