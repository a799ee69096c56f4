"""A RoboteQ dual-channel controller emulator on a pseudo-terminal (from the command manual).

Answers ``!G ch v`` (per mille of MXRPM), ``!S ch rpm``, ``?C [ch]`` (absolute counts,
signed 32-bit, wrapping), ``?CR [ch]`` (counts since the last ``?CR``), ``?V``
(``internal:battery:5V`` in volts x10, volts x10, mV), ``?BA`` (battery current per channel,
amps x10), ``?FF`` (fault flags), ``^ECHOF n`` and ``^RWD ms``; ``+``/``-`` acknowledge; every
reply ends with CR. The echo is on until ``^ECHOF 1``.

Motors follow their command instantly (no acceleration ramp) and the encoder counts integrate
``rpm / 60 * counts_per_rev`` per second. The serial watchdog behaves as the manual says: only
``!`` commands refresh it; after ``RWD`` ms of silence the motors stop, and "as soon as a valid
command is received, motor operation will resume at whichever speed motors were running prior
to the watchdog timeout" — both channels resume, then the new command applies to its channel.
`resumed` logs each such resumption (the trap a driver must defuse by sending zero first).

Fault injection: `fault_flags`, `send_garbage`, `drop_replies`, `unplug`.

Run stand-alone: ``python -m tests.robot_daemon.hardware.emulators.roboteq_emulator --pty``.
"""

from __future__ import annotations

import argparse
import logging
import threading
from collections.abc import Callable
from pathlib import Path

from tests.robot_daemon.hardware.emulators.pty_port import EmulatorThread, serve_forever

logger = logging.getLogger(__name__)

_INT32 = 1 << 32


def _wrap_int32(value: float) -> int:
    v = round(value) % _INT32
    return v - _INT32 if v >= _INT32 // 2 else v


class RoboteqEmulator(EmulatorThread):
    """Two motors with quadrature encoders behind a RoboteQ serial interface."""

    name = "roboteq-emulator"

    def __init__(
        self,
        link: Path | None = None,
        counts_per_rev: float = 2048.0,
        max_rpm: float = 3000.0,
        battery_volts: float = 29.6,
        idle_amps: float = 0.8,  # per channel [A]
        amps_per_krpm: float = 1.5,  # per channel [A per 1000 rpm]
        start_counts: tuple[int, int] = (0, 0),
    ) -> None:
        super().__init__(link)
        self.counts_per_rev = counts_per_rev
        self.max_rpm = max_rpm
        self.battery_volts = battery_volts
        self.idle_amps = idle_amps
        self.amps_per_krpm = amps_per_krpm
        self.echo = True
        self.watchdog_ms = 1000
        self.fault_flags = 0
        self._target_rpm = [0.0, 0.0]
        self._counts = [float(start_counts[0]), float(start_counts[1])]
        self._relative_ref = [0, 0]
        self._last_bang: float | None = None
        self._tripped = False
        self._last_tick: float | None = None
        self._rx = bytearray()
        self._drop = 0
        self.trips = 0
        self.commands: list[str] = []
        #: (channel, rpm) of each channel that resumed its pre-trip speed after a trip and
        #: was still running it once the batch of commands that woke it was processed.
        self.resumed: list[tuple[int, float]] = []
        self._resuming: dict[int, float] = {}
        #: What the motors did after each batch of commands and each watchdog trip, in order:
        #: a test waits on this history, not on the present state, which lasts only until
        #: the watchdog trips (a loaded machine may not look within those ``RWD`` ms).
        self.applied_log: list[tuple[float, float]] = []
        self.changed = threading.Condition(self._lock)

    # -- inspection and fault injection -------------------------------------------------------

    @property
    def applied_rpm(self) -> tuple[float, float]:
        """What the motors are doing now (zero while the watchdog has tripped)."""
        with self._lock:
            if self._tripped:
                return (0.0, 0.0)
            return (self._target_rpm[0], self._target_rpm[1])

    @property
    def tripped(self) -> bool:
        with self._lock:
            return self._tripped

    def counts(self) -> tuple[int, int]:
        with self._lock:
            return (_wrap_int32(self._counts[0]), _wrap_int32(self._counts[1]))

    def set_counts(self, left: int, right: int) -> None:
        with self._lock:
            self._counts = [float(left), float(right)]

    def set_fault_flags(self, flags: int) -> None:
        with self._lock:
            self.fault_flags = flags

    def send_garbage(self, data: bytes) -> None:
        """Write raw bytes to the driver (line noise)."""
        with self._lock:
            self.pty.write(data)

    def drop_replies(self, count: int) -> None:
        """Ignore the next ``count`` commands (no reply)."""
        with self._lock:
            self._drop += count

    def has_applied(self, predicate: Callable[[tuple[float, float]], bool], since: int = 0) -> bool:
        """Whether the motors did something matching ``predicate`` at any time after the
        first ``since`` entries of `applied_log`."""
        with self._lock:
            return any(predicate(rpm) for rpm in self.applied_log[since:])

    def wait_for(self, predicate: object, timeout: float) -> bool:
        """Wait until ``predicate()`` holds (checked after every processed command or tick)."""
        with self.changed:
            return self.changed.wait_for(predicate, timeout)  # type: ignore[arg-type]

    # -- EmulatorThread -----------------------------------------------------------------------

    def _on_replug(self, now: float) -> None:
        self._rx.clear()
        self.echo = True
        self._tripped = True  # silence while unplugged: the watchdog has stopped the motors
        self.applied_log.append((0.0, 0.0))
        self._last_bang = None

    def _tick(self, now: float) -> None:
        if self._last_tick is not None:
            dt = now - self._last_tick
            if not self._tripped:
                for ch in (0, 1):
                    self._counts[ch] += self._target_rpm[ch] / 60.0 * self.counts_per_rev * dt
        self._last_tick = now
        if (
            self.watchdog_ms > 0
            and not self._tripped
            and self._last_bang is not None
            and (now - self._last_bang) * 1000.0 > self.watchdog_ms
        ):
            self._tripped = True
            self.trips += 1
            self.applied_log.append((0.0, 0.0))
            logger.debug("RoboteQ emulator: serial watchdog tripped")
        self.changed.notify_all()

    def _on_bytes(self, data: bytes, now: float) -> None:
        self._tick(now)  # integrate up to the arrival of the command
        self._rx += data
        while (end := self._rx.find(b"\r")) >= 0:
            line = bytes(self._rx[:end]).strip(b"\n ")
            del self._rx[: end + 1]
            if line:
                self._handle(line.decode("ascii", errors="replace"), now)
        self.resumed += sorted(self._resuming.items())
        self._resuming.clear()
        applied = (0.0, 0.0) if self._tripped else (self._target_rpm[0], self._target_rpm[1])
        if not self.applied_log or self.applied_log[-1] != applied:
            self.applied_log.append(applied)
        if len(self._rx) > 512:
            self._rx.clear()
        self.changed.notify_all()

    # -- commands -----------------------------------------------------------------------------

    def _send(self, text: str) -> None:
        self.pty.write(text.encode("ascii") + b"\r")

    def _handle(self, text: str, now: float) -> None:
        self.commands.append(text)
        if self._drop:
            self._drop -= 1
            return
        if self.echo:
            self._send(text)
        parts = text.split()
        head = parts[0].upper()
        try:
            args = [int(p) for p in parts[1:]]
        except ValueError:
            self._send("-")
            return
        if head.startswith("!"):
            self._motor_command(head, args, now)
        elif head.startswith("?"):
            self._query(head[1:], args)
        elif head in ("^ECHOF", "^RWD") and len(args) == 1:
            if head == "^ECHOF":
                self.echo = args[0] == 0
            else:
                self.watchdog_ms = args[0]
            self._send("+")
        else:
            self._send("-")

    def _motor_command(self, head: str, args: list[int], now: float) -> None:
        if head not in ("!G", "!S") or len(args) != 2 or args[0] not in (1, 2):
            self._send("-")
            return
        self._last_bang = now
        if self._tripped:
            # The trap: both channels resume what they did before the watchdog stopped them.
            self._tripped = False
            self._resuming = {ch + 1: rpm for ch, rpm in enumerate(self._target_rpm) if rpm}
        ch, value = args[0] - 1, args[1]
        self._resuming.pop(ch + 1, None)
        if head == "!G":
            value = max(-1000, min(1000, value))
            self._target_rpm[ch] = value / 1000.0 * self.max_rpm
        else:
            self._target_rpm[ch] = max(-self.max_rpm, min(self.max_rpm, float(value)))
        self._send("+")

    def _query(self, name: str, args: list[int]) -> None:
        channels = [args[0] - 1] if args and args[0] in (1, 2) else [0, 1]
        if name == "C":
            values = [_wrap_int32(self._counts[ch]) for ch in channels]
        elif name == "CR":
            values = []
            for ch in channels:
                now_counts = _wrap_int32(self._counts[ch])
                values.append(_wrap_int32(now_counts - self._relative_ref[ch]))
                self._relative_ref[ch] = now_counts
        elif name == "V":
            values = [120, round(self.battery_volts * 10), 5000]
        elif name == "BA":
            rpm = self.applied_rpm
            values = [
                round((self.idle_amps + self.amps_per_krpm * abs(rpm[ch]) / 1000.0) * 10)
                for ch in channels
            ]
        elif name == "FF":
            values = [self.fault_flags]
        else:
            self._send("-")
            return
        self._send(f"{name}=" + ":".join(str(v) for v in values))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="RoboteQ motor controller emulator on a pty")
    parser.add_argument("--pty", action="store_true", help="serve on a new pseudo-terminal")
    parser.add_argument("--link", type=Path, help="also make this symlink to the pty")
    parser.add_argument("--counts-per-rev", type=float, default=2048.0)
    parser.add_argument("--max-rpm", type=float, default=3000.0)
    args = parser.parse_args(argv)
    if not args.pty:
        parser.error("only --pty is supported")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    emulator = RoboteqEmulator(
        link=args.link, counts_per_rev=args.counts_per_rev, max_rpm=args.max_rpm
    )
    serve_forever(emulator)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
