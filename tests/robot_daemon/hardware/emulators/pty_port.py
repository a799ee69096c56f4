"""A pseudo-terminal that plays a serial device, and the thread base class of the emulators.

``os.openpty()`` gives a (master, slave) pair; the slave is put in raw mode at once (otherwise
its line discipline would echo the emulator's own output back to it) and the driver opens
``os.ttyname(slave)`` with pyserial, exactly as it opens /dev/ttyACM0. The emulator keeps its
own slave descriptor open so that the driver closing and reopening the port does not hang up
the master. With ``link`` the port is also reachable through a symlink that survives an
"unplug" (the pty pair is destroyed; the driver sees EIO) and a "replug" (a new pair behind
the same link), like a udev ``/dev/serial/by-id`` name.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import signal
import threading
import time
import tty
from pathlib import Path
from typing import Self

logger = logging.getLogger(__name__)


class PtyPort:
    """The device side of a pseudo-terminal (non-blocking master)."""

    def __init__(self, link: Path | None = None) -> None:
        self.link = link
        self.master = -1
        self._slave = -1
        self.slave_path = ""
        self.dropped_bytes = 0  # output the reader did not take in time (device buffer full)
        self.open()

    @property
    def port(self) -> str:
        """The path a driver should open (the link if there is one)."""
        return str(self.link) if self.link is not None else self.slave_path

    @property
    def is_open(self) -> bool:
        return self.master >= 0

    def open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self.master, self._slave = master, slave
        self.slave_path = os.ttyname(slave)
        if self.link is not None:
            tmp = self.link.with_name(self.link.name + ".tmp")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            tmp.symlink_to(self.slave_path)
            os.replace(tmp, self.link)

    def close(self) -> None:
        """Destroy the pair (an unplug): the driver's next read fails."""
        for fd in (self.master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self.master = self._slave = -1
        if self.link is not None:
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()

    def read(self, timeout: float) -> bytes:
        """Bytes written by the driver, waiting at most ``timeout`` [s]; b"" if none."""
        if self.master < 0:
            time.sleep(timeout)
            return b""
        ready, _, _ = select.select([self.master], [], [], max(timeout, 0.0))
        if not ready:
            return b""
        try:
            return os.read(self.master, 65536)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            # EIO while no process has the slave open; wait instead of spinning.
            time.sleep(timeout)
            return b""

    def write(self, data: bytes, timeout: float = 0.2) -> None:
        """Write all of ``data`` unless the reader stalls for ``timeout``; the rest is dropped."""
        view = memoryview(data)
        deadline = time.monotonic() + timeout
        while view and self.master >= 0:
            try:
                n = os.write(self.master, view)
                view = view[n:]
                continue
            except BlockingIOError:
                pass
            except OSError:
                break
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            select.select([], [self.master], [], min(remaining, 0.01))
        self.dropped_bytes += len(view)


class EmulatorThread:
    """Runs ``_tick(now)`` and ``_on_bytes(data, now)`` on a background thread until `stop`."""

    name = "emulator"

    def __init__(self, link: Path | None = None, tick: float = 0.002) -> None:
        self.pty = PtyPort(link)
        self._tick_period = tick
        self._stop = threading.Event()
        self._lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._unplugged_until: float | None = None
        self.unplugs = 0

    @property
    def port(self) -> str:
        return self.pty.port

    def start(self) -> Self:
        self._thread = threading.Thread(target=self._run, name=self.name, daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                logger.error("%s thread did not stop within %.1f s", self.name, timeout)
        self.pty.close()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def unplug(self, replug_after: float | None = 0.3) -> None:
        """Destroy the port now; recreate it (same link, reset device) after ``replug_after`` s."""
        with self._lock:
            self.pty.close()
            self.unplugs += 1
            self._unplugged_until = (
                float("inf") if replug_after is None else time.monotonic() + replug_after
            )

    def replug(self) -> None:
        """Recreate an unplugged port now (after ``unplug(replug_after=None)``)."""
        with self._lock:
            if self._unplugged_until is not None:
                self._unplugged_until = time.monotonic()

    def _run(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            with self._lock:
                if self._unplugged_until is not None and now >= self._unplugged_until:
                    self._unplugged_until = None
                    self.pty.open()
                    self._on_replug(now)
            if self._unplugged_until is not None:
                self._stop.wait(0.01)
                continue
            data = self.pty.read(self._tick_period)
            now = time.monotonic()
            with self._lock:
                if data:
                    self._on_bytes(data, now)
                self._tick(now)

    # -- for subclasses ---------------------------------------------------------------------

    def _on_bytes(self, data: bytes, now: float) -> None:
        raise NotImplementedError

    def _tick(self, now: float) -> None:
        raise NotImplementedError

    def _on_replug(self, now: float) -> None:
        """Reset the device state after a replug (default: nothing)."""


def serve_forever(emulator: EmulatorThread) -> None:
    """Run an emulator until SIGINT or SIGTERM, printing the port (command-line entry points)."""
    done = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        done.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    emulator.start()
    print(emulator.port, flush=True)  # command-line output: the port to put in robot.yaml
    try:
        while not done.wait(1.0):
            pass
    finally:
        emulator.stop()
