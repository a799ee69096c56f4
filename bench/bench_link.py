"""Benchmark: one-way pose latency over the zenoh link on loopback, `RobotLink.publish` of a pose to
receipt (``link_pose_ms_median`` / ``_p99`` / ``_max``).

Two sessions in one process (robot listens on 127.0.0.1, station connects), the robot's
`RobotLink` publishes a `PoseMsg` whose ``stamp`` is ``time.perf_counter()`` at send time and a
station-side subscriber blocks in ``recv()`` on a FIFO channel and decodes it; one pose in
flight at a time, so the figure is link latency, not queueing. Run:
``.venv/bin/interbot bench --only link`` (``--secure``: mutual TLS and access control with
keys made in a temporary directory, issue 15), or ``python bench/bench_link.py [--secure]``.
"""

from __future__ import annotations

import importlib.util
import logging
import socket
import statistics
import sys
import tempfile
import time
from pathlib import Path

import zenoh

from interbot_core.topics import PoseMsg, Topic, decode, key
from interbot_link.keys import KeyStore
from interbot_link.robot import RobotLink
from interbot_link.security import LinkSecurity
from interbot_link.session import open_session

logger = logging.getLogger(__name__)

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]


def free_loopback_port() -> int:
    """A TCP port on 127.0.0.1 the OS considers free right now (it may be taken again later)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def bench_link(samples: int = 2000, warmup: int = 100, secure: bool = False) -> dict[str, float]:
    """Median, p99 and max one-way pose latency [ms] over ``samples`` sequential poses."""
    if not secure:
        return _bench(f"tcp/127.0.0.1:{free_loopback_port()}", None, None, samples, warmup)
    with tempfile.TemporaryDirectory(prefix="interbot-keys-") as tmp:
        members = (("bench", "robot"), ("station", "station"))
        keys = KeyStore.init(Path(tmp) / "keys", members).dir
        robot = LinkSecurity.load(keys, "bench", "robot")
        station = LinkSecurity.load(keys, "station", "station")
        endpoint = f"tls/127.0.0.1:{free_loopback_port()}"
        return _bench(endpoint, robot, station, samples, warmup)


def _bench(
    endpoint: str,
    robot_security: LinkSecurity | None,
    station_security: LinkSecurity | None,
    samples: int,
    warmup: int,
) -> dict[str, float]:
    with (
        open_session([endpoint], [], security=robot_security) as robot_session,
        open_session([], [endpoint], security=station_security) as station,
    ):
        link = RobotLink(robot_session, "bench")
        sub = station.declare_subscriber(key("bench", Topic.POSE), zenoh.handlers.FifoChannel(16))
        try:
            deadline = time.perf_counter() + 5.0
            while not station.info.peers_zid() and time.perf_counter() < deadline:
                time.sleep(0.01)  # wait for the TCP link
            time.sleep(0.05)  # and for the subscription to reach the robot
            latencies: list[float] = []
            for i in range(samples + warmup):
                link.publish(Topic.POSE, PoseMsg(0.0, 0.0, 0.0, stamp=time.perf_counter()))
                sample = sub.recv()
                pose = decode(Topic.POSE, sample.payload.to_bytes())
                arrived = time.perf_counter()
                if not isinstance(pose, PoseMsg):
                    raise TypeError(f"expected a PoseMsg on {Topic.POSE}, got {pose!r}")
                if i >= warmup:
                    latencies.append((arrived - pose.stamp) * 1000.0)
        finally:
            sub.undeclare()
            link.close()
    latencies.sort()
    return {
        "samples": float(len(latencies)),
        "median_ms": statistics.median(latencies),
        "p99_ms": latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))],
        "max_ms": latencies[-1],
    }


def run(quick: bool = False, secure: bool = False) -> dict[str, float]:
    samples, warmup = (30, 5) if quick else (2000, 100)
    with common.quiet_logs():
        result = bench_link(samples, warmup, secure=secure)
    return {
        "link_pose_samples": result["samples"],
        "link_pose_ms_median": result["median_ms"],
        "link_pose_ms_p99": result["p99_ms"],
        "link_pose_ms_max": result["max_ms"],
    }


def main() -> int:
    secure = "--secure" in sys.argv[1:]
    result = bench_link(secure=secure)
    sys.stdout.write(
        ("mutual TLS + ACL: " if secure else "plain TCP: ")
        + "one-way pose latency on loopback: median {median_ms:.3f} ms, p99 {p99_ms:.3f} ms, "
        "max {max_ms:.3f} ms over {samples:.0f} samples\n".format(**result)
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
