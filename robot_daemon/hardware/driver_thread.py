"""The worker thread of a device driver (the laser, the motor controller, the camera).

Each driver talks to its device in one daemon thread and shares results under ``_lock``:
`start` starts the thread, `close` asks it to stop (``_stop``), wakes it and joins it (logging
a thread that did not stop in time). ``close`` is idempotent; the thread releases its device on
the way out (the laser sends QT/RS, the motor controller zero on both channels).
"""

from __future__ import annotations

import logging
import threading
from typing import Self

logger = logging.getLogger(__name__)


class DriverThread:
    """Start/stop of a driver's thread, which runs ``_run`` until ``_stop`` is set."""

    THREAD_NAME = "driver"

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

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

    def _wake_up(self) -> None:
        """Interrupt a wait on something other than ``_stop`` (overridden where there is one)."""

    def _run(self) -> None:
        raise NotImplementedError
