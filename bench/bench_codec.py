"""Benchmark: encode and decode time per message kind, tablet protocol and zenoh topics (issue 13).

For each kind, one representative message is encoded to bytes and decoded back (the tablet
protocol: `encode`, then `parse_frame` + `decode_tablet_message`/`decode_station_message`, as
the station and the tablet do per frame; the zenoh topics: `topics.encode` / `topics.decode`).
Each figure is the median and p99 of ``REPEATS`` batch timings, each batch ``BATCH`` calls,
divided by ``BATCH`` [µs per call]; timing uses time.perf_counter here only.

    .venv/bin/interbot bench --only codec         (or --quick for fewer batches)
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from interbot_core import protocol as p
from interbot_core import topics as t
from interbot_core.laser_scan import LaserScan

BATCH = 200
REPEATS = 200
QUICK_REPEATS = 30

LIMITS = p.ProtocolLimits(max_linear=0.6, max_angular=1.0, node_ids=frozenset(range(22)))

TABLET: dict[str, p.Message] = {
    "speed": p.Speed(0.25, -0.5, seq=1234, t=5678.125),
    "goal": p.Goal(7),
    "requestFrom": p.RequestFrom("the blue folder, please", 4, 9, True),
    "ping": p.Ping(12, 3.25),
}
STATION: dict[str, p.Message] = {
    "pose": p.Pose(1.5, -2.0, 0.785),
    "goal_status": p.GoalStatus(7, False, True),
    "tour_state": p.TourState((1, 3, 5, 7, 9), (1, 3), 5),
    "status": p.StatusInfo("goal 7", "on the way to the meeting room"),
    "safety": p.SafetyInfo("slowdown", 0.42, True),
}


def _scan() -> LaserScan:
    ranges = np.random.default_rng(0).uniform(0.1, 30.0, 1081).astype(np.float32)
    return LaserScan(
        angle_min=-2.35619,
        angle_increment=0.004363,
        range_min=0.1,
        range_max=30.0,
        ranges=ranges,
        stamp=12.5,
    )


TOPICS: dict[t.Topic, object] = {
    t.Topic.TABLET_VEL: t.Twist(0.25, -0.5, 1234.5),
    t.Topic.POSE: t.PoseMsg(1.5, -2.0, 0.785, 1234.5),
    t.Topic.ROUTE: t.RouteMsg(
        route_id=2**40 + 7,
        waypoints=tuple((float(i), float(i) / 2, 0.1) for i in range(20)),
        node_ids=tuple(range(20)),
    ),
    t.Topic.MUX: t.MuxMsg("tablet_vel", "highest priority", ("pause_nav",), 0.2, 0.1, 3.0),
    t.Topic.SAFETY: t.SafetyMsg("slowdown", "front", 0.42, 1.5, 0.6, ("tablet_vel",), "scaled"),
    t.Topic.SCAN: _scan(),
}


def _per_call_us(fn: Callable[[], object], repeats: int) -> tuple[float, float]:
    samples = np.empty(repeats)
    for r in range(repeats):
        start = time.perf_counter()
        for _ in range(BATCH):
            fn()
        samples[r] = (time.perf_counter() - start) / BATCH
    p50, p99 = np.percentile(samples * 1e6, [50.0, 99.0])
    return float(p50), float(p99)


def _figures(name: str, encode: Callable[[], bytes], decode: Callable[[bytes], object], repeats: int) -> dict[str, float]:  # fmt: skip
    data = encode()
    out: dict[str, float] = {}
    for verb, fn in (("encode", encode), ("decode", lambda: decode(data))):
        p50, p99 = _per_call_us(fn, repeats)
        out[f"{name}_{verb}_us_median"] = p50
        out[f"{name}_{verb}_us_p99"] = p99
    return out


def run(quick: bool = False) -> dict[str, Any]:
    repeats = QUICK_REPEATS if quick else REPEATS
    figures: dict[str, Any] = {}
    apps = (
        ("tablet", TABLET, p.decode_tablet_message),
        ("station", STATION, p.decode_station_message),
    )
    for side, messages, decode in apps:
        for name, msg in messages.items():
            figures |= _figures(
                f"{side}_{name}",
                lambda m=msg: p.encode(m),
                lambda b, d=decode: d(p.parse_frame(b.rstrip()), LIMITS),
                repeats,
            )
    for topic, msg in TOPICS.items():
        figures |= _figures(
            f"topic_{topic}",
            lambda tp=topic, m=msg: t.encode(tp, m),
            lambda b, tp=topic: t.decode(tp, b),
            repeats,
        )
    return figures


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:<40} {value:.2f}")
