"""The tablet and the mux observer of `bench_teleop`, in a process of their own.

Run by `bench_teleop` as ``python bench/_teleop_tablet.py CONFIG_JSON``; prints one JSON object
(the samples) as its last line. It connects to the station's tablet port as the thesis's bare
JSON client (or the paired TLS tablet with ``--secure``), subscribes to the robot's ``mux``
topic on its own zenoh session, and for each sample waits a random 0-100 ms, writes a new,
distinct speed and waits until the mux output carries exactly that speed.

Why its own process (issue 14): in the station's process the observer's zenoh callback and
the writes shared the GIL and the Qt thread with the station being measured; a frame being
drawn delayed the *observer's* time stamp and the *tablet's* write as well as the station. A
real tablet and a real robot are other machines. Time stamps are ``time.monotonic()``
(CLOCK_MONOTONIC: one clock for every process on the machine), so the station's arrival
stamps taken in the bench process split each sample.

The observer's zenoh callback thread runs at the command threads' real-time priority where the
OS allows it (`interbot_link.command_priority`, as the station's tablet thread and the daemon's
command threads do): it is the instrument, and its own wait for a busy CPU is not the robot's
latency. ``INTERBOT_REALTIME=0`` turns it off with the rest. So do its zenoh network threads
(`NamedThreadRaiser`, as the station and the daemon raise theirs), looked for before the first
sample and after every sample (outside the timed interval).
"""

from __future__ import annotations

import hashlib
import json
import socket
import ssl
import sys
import threading
import time
from typing import Any

import numpy as np
import zenoh

from interbot_core.topics import MuxMsg, Topic, decode, key
from interbot_link import LinkSecurity, session_config
from interbot_link.command_priority import NamedThreadRaiser, ThreadRaiser

ANGULAR_MIN, ANGULAR_MAX = 0.1, 0.7
"""[rad/s] the commands' turn rates: under the robot multiplexer's tablet limit
(``max_angular: 1.0`` in interbot_mux.yaml), which scales a faster command down: the mux would
then never carry the exact speed and the sample would time out. (The first 1,200-sample run
turned up to 2.5 rad/s: every sample from the 451st on timed out, 2 s each.)"""
MAX_CONSECUTIVE_MISSES = 10
"""So many samples in a row not seen at the mux: the run stops and says why (no long hang)."""


def speed_value(i: int, n_samples: int = 300) -> tuple[float, float]:
    """The ``i``-th of ``n_samples`` distinct commands: turn on the spot, alternating
    direction, the rate growing from `ANGULAR_MIN` by 2 mrad/s (finer for more than 300
    samples, so that every one stays at most `ANGULAR_MAX`)."""
    if not 0 <= i < n_samples:
        raise ValueError(f"sample index {i} outside 0..{n_samples - 1}")
    step = min(0.002, (ANGULAR_MAX - ANGULAR_MIN) / n_samples)
    return 0.0, round((-1.0) ** i * (ANGULAR_MIN + step * i), 6)


def tls_tablet(raw: socket.socket, fingerprint: str, token: str) -> socket.socket:
    """TLS over ``raw``, pinned on ``fingerprint``, authenticated with ``token``."""
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    context.check_hostname = False
    context.verify_mode = ssl.CERT_NONE  # pinned below, as tablet_app.pairing does
    tls = context.wrap_socket(raw, server_hostname="station")
    der = tls.getpeercert(binary_form=True) or b""
    if hashlib.sha256(der).hexdigest() != fingerprint:
        raise SystemExit("bench_teleop: the station's certificate is not the pinned one")
    tls.sendall(json.dumps({"auth": {"token": token}}).encode() + b"\n")
    reply = b""
    while b"\n" not in reply:
        chunk = tls.recv(4096)
        if not chunk:
            raise SystemExit("bench_teleop: the station closed the TLS tablet")
        reply += chunk
    if b"authorised" not in reply:
        raise SystemExit(f"bench_teleop: tablet not authorised: {reply!r}")
    return tls


class MuxWatch:
    """Time stamps the first ``mux`` sample carrying the expected speed (zenoh thread)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.expected: tuple[float, float] | None = None
        self.seen: set[str] = set()
        self.stamp = 0.0
        self.hit = threading.Event()
        self.raise_thread = ThreadRaiser("the bench's mux observer")

    def expect(self, value: tuple[float, float]) -> None:
        with self.lock:
            self.expected, self.stamp = value, 0.0
            self.seen = set()
            self.hit.clear()

    def on_sample(self, sample: zenoh.Sample) -> None:
        stamp = time.monotonic()  # first, before any decoding
        self.raise_thread()  # once per callback thread (see the module docstring)
        msg = decode(Topic.MUX, sample.payload.to_bytes())
        if not isinstance(msg, MuxMsg):
            return
        with self.lock:
            expected = self.expected
            if expected is None or self.hit.is_set():
                return
            self.seen.add(f"{msg.source}/{msg.reason} ({msg.linear:g}, {msg.angular:g})")
            if abs(msg.linear - expected[0]) < 1e-6 and abs(msg.angular - expected[1]) < 1e-6:
                self.stamp = stamp
                self.hit.set()


def drain(tablet: socket.socket) -> None:
    """Read and drop what the station sent (pings, status): never let its buffer fill."""
    while True:
        try:
            if not tablet.recv(65536):
                raise SystemExit("bench_teleop: the station closed the tablet")
        except (BlockingIOError, ssl.SSLWantReadError):
            return


def main(config: dict[str, Any]) -> dict[str, Any]:
    security = None
    if config.get("keys"):
        security = LinkSecurity.load(config["keys"], "observer", "observer")
    session = zenoh.open(session_config([], [config["endpoint"]], security=security))
    watch = MuxWatch()
    subscriber = session.declare_subscriber(key(config["robot"], Topic.MUX), watch.on_sample)
    tablet = socket.create_connection(("127.0.0.1", config["port"]), timeout=5.0)
    tablet.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    if config.get("fingerprint"):
        tablet = tls_tablet(tablet, config["fingerprint"], config["token"])
    tablet.setblocking(False)
    print("connected", flush=True)  # the bench waits for this line before it starts timing
    time.sleep(config.get("settle_s", 1.0))  # the station's connect-time messages go by
    network = NamedThreadRaiser("the bench observer's zenoh threads")
    network.scan()
    rng = np.random.default_rng(config["seed"])
    written: list[tuple[float, float, float]] = []  # (linear, angular, t_write)
    observed: list[tuple[float, float, float]] = []  # (linear, angular, t_mux)
    reasons: dict[str, int] = {}
    misses = 0  # in a row
    aborted = ""
    try:
        for i in range(config["samples"]):
            time.sleep(int(rng.integers(0, 101)) / 1000.0)  # a random phase against clock()
            drain(tablet)
            value = speed_value(i, config["samples"])
            frame = json.dumps({"speed": {"linear": value[0], "angular": value[1]}}).encode()
            watch.expect(value)
            t_write = time.monotonic()
            tablet.sendall(frame)
            written.append((*value, t_write))
            if watch.hit.wait(config["timeout_s"]):
                observed.append((*value, watch.stamp))
                misses = 0
            else:
                with watch.lock:
                    why = " | ".join(sorted(watch.seen)) or "no mux output"
                reasons[why] = reasons.get(why, 0) + 1
                misses += 1
                if misses >= MAX_CONSECUTIVE_MISSES:
                    aborted = f"{misses} samples in a row not seen at the mux (last: {why})"
                    break
            network.scan()  # zenoh may have started another network thread
    finally:
        subscriber.undeclare()
        tablet.close()
        session.close()
    return {"written": written, "observed": observed, "miss_reasons": reasons, "aborted": aborted}


if __name__ == "__main__":
    print(json.dumps(main(json.loads(sys.argv[1]))), flush=True)  # command-line output
