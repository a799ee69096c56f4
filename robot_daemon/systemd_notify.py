"""systemd's notification protocol (sd_notify(3)) without a library.

One AF_UNIX datagram per message to ``$NOTIFY_SOCKET`` (a leading ``@`` means the abstract
namespace). ``READY=1`` once the daemon serves, ``WATCHDOG=1`` from the control loop itself at
half of ``$WATCHDOG_USEC`` (so a stuck loop gets the unit restarted), ``STOPPING=1`` on SIGTERM.
Without ``NOTIFY_SOCKET`` every call is a no-op, so the daemon runs the same outside systemd.
"""

from __future__ import annotations

import logging
import os
import socket

logger = logging.getLogger(__name__)


class SystemdNotifier:
    """Sends sd_notify messages; rate-limits watchdog pings to half the configured period."""

    def __init__(self, environ: dict[str, str] | None = None) -> None:
        env = os.environ if environ is None else environ
        self._address = self._parse_address(env.get("NOTIFY_SOCKET", ""))
        usec = env.get("WATCHDOG_USEC", "")
        self.watchdog_period: float | None = None  # [s] half of WATCHDOG_USEC
        if usec:
            try:
                value = int(usec)
            except ValueError:
                logger.warning("ignoring WATCHDOG_USEC=%r: not an integer", usec)
            else:
                if value > 0:
                    self.watchdog_period = value / 2e6
        self._last_ping: float | None = None
        self._socket: socket.socket | None = None

    @staticmethod
    def _parse_address(raw: str) -> str | bytes | None:
        if not raw:
            return None
        if raw.startswith("@"):
            return b"\0" + raw[1:].encode()
        if raw.startswith("/"):
            return raw
        logger.warning("ignoring NOTIFY_SOCKET=%r: not a unix socket path", raw)
        return None

    @property
    def enabled(self) -> bool:
        return self._address is not None

    def notify(self, message: str) -> bool:
        """Send one message (e.g. ``READY=1``); False when not under systemd or on error."""
        if self._address is None:
            return False
        try:
            if self._socket is None:
                self._socket = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            self._socket.sendto(message.encode(), self._address)
        except OSError as exc:
            logger.warning("sd_notify %r failed: %s", message, exc)
            return False
        return True

    def ready(self, status: str = "") -> bool:
        return self.notify("READY=1" + (f"\nSTATUS={status}" if status else ""))

    def stopping(self) -> bool:
        return self.notify("STOPPING=1")

    def watchdog(self, now: float) -> bool:
        """Ping the watchdog if half its period has passed since the last ping (``now`` [s])."""
        if self.watchdog_period is None:
            return False
        if self._last_ping is not None and now - self._last_ping < self.watchdog_period:
            return False
        self._last_ping = now
        return self.notify("WATCHDOG=1")

    def close(self) -> None:
        if self._socket is not None:
            self._socket.close()
            self._socket = None
