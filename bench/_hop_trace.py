"""Diagnostic: per-hop time stamps of the teleop bench's commands (``TELEOP_TRACE=DIR``).

    TELEOP_TRACE=/tmp/trace interbot bench --only teleop --json
    python bench/_hop_trace.py report /tmp/trace     # every hop's p50 / p99, the slowest 3 %

Not part of any program: `bench_teleop` installs it in its station process and runs the
daemon through ``python bench/_hop_trace.py daemon ARGS...`` when ``TELEOP_TRACE`` names a
directory. It wraps (monkeypatches) the functions on the command path and the daemon's long
loop sections, stamping ``time.monotonic()`` (CLOCK_MONOTONIC: one clock for the machine, the
one ``perf sched record -k CLOCK_MONOTONIC`` can use too), and writes ``<DIR>/<role>.json``
(spans: name, key, t_start, t_end, thread) and ``<role>.tids.json`` (thread ids) at exit.
A ``probe`` thread records when a thread that slept 2 ms woke 1.5 ms late or more.

Experiment knobs (issue 14's investigation): ``TELEOP_TRACE_RT=1`` puts the command-path
threads under SCHED_FIFO from here (``TELEOP_TRACE_RT_ZENOH=0``: not zenoh's rx/tx threads),
``TELEOP_TRACE_SWITCH=S`` sets ``sys.setswitchinterval(S)`` in the station and the daemon
(``TELEOP_TRACE_SWITCH_ROLE=station`` or ``daemon``: in that one only).
"""

from __future__ import annotations

import atexit
import functools
import json
import os
import runpy
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

EVENTS: list[tuple[str, Any, float, float, str]] = []
TIDS: dict[str, int] = {}  # Python thread name -> the OS thread id (perf sched)


def _record(name: str, key: Any, t0: float, t1: float) -> None:
    thread = threading.current_thread().name
    EVENTS.append((name, key, t0, t1, thread))
    if thread not in TIDS:
        TIDS[thread] = threading.get_native_id()


def _span(obj: Any, attr: str, name: str, key: Callable[..., Any] | None = None) -> None:
    """Wrap ``obj.attr`` so each call records a span named ``name``."""
    original = getattr(obj, attr)

    @functools.wraps(original)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.monotonic()
        try:
            return original(*args, **kwargs)
        finally:
            _record(name, key(*args, **kwargs) if key is not None else None, t0, time.monotonic())

    setattr(obj, attr, wrapper)


def _probe(period_s: float = 0.002, late_s: float = 0.0015) -> None:
    """A thread that sleeps ``period_s`` and records when it woke ``late_s`` or more late:
    the GIL or a CPU was not available to a thread that wanted it."""

    def run() -> None:
        while True:
            t0 = time.monotonic()
            time.sleep(period_s)
            t1 = time.monotonic()
            if t1 - t0 - period_s >= late_s:
                _record("probe_late", None, t0 + period_s, t1)

    threading.Thread(target=run, name="probe", daemon=True).start()


RT = os.environ.get("TELEOP_TRACE_RT") == "1"  # experiment: path threads SCHED_FIFO
_boosted: set[int] = set()


def _boost(tid: int = 0) -> None:
    tid = tid or threading.get_native_id()
    if RT and tid not in _boosted:
        _boosted.add(tid)
        os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(10))


def _boost_zenoh_threads(delay_s: float = 4.0) -> None:
    def run() -> None:
        time.sleep(delay_s)
        for task in Path("/proc/self/task").iterdir():
            comm = (task / "comm").read_text().strip()
            if comm.startswith(("rx-", "tx-")):
                _boost(int(task.name))

    if RT and os.environ.get("TELEOP_TRACE_RT_ZENOH", "1") == "1":
        threading.Thread(target=run, daemon=True).start()


def _dump(path: Path) -> None:
    path.write_text(json.dumps(EVENTS), encoding="utf-8")
    path.with_suffix(".tids.json").write_text(json.dumps({"pid": os.getpid(), **TIDS}))


def _twist_key(payload: bytes) -> float | None:
    from interbot_core.topics import Topic, decode

    try:
        return float(decode(Topic.TABLET_VEL, payload).angular)  # type: ignore[attr-defined]
    except Exception:
        return None


def _switch_interval(role: str) -> None:
    value = os.environ.get("TELEOP_TRACE_SWITCH")
    if value and os.environ.get("TELEOP_TRACE_SWITCH_ROLE", role) == role:
        sys.setswitchinterval(float(value))


def install_daemon(out: Path) -> None:
    _switch_interval("daemon")
    from interbot_link import robot as robot_mod
    from robot_daemon import daemon as daemon_mod
    from robot_daemon import stack as stack_mod
    from robot_daemon.localisation import localiser as loc_mod
    from robot_daemon.planning import navigator as nav_mod
    from robot_daemon.sim import simulator as sim_mod

    link_cls = robot_mod.RobotLink
    on_sample = link_cls._on_sample

    def traced_on_sample(self: Any, sample: Any) -> None:
        _boost()
        t0 = time.monotonic()
        on_sample(self, sample)
        t1 = time.monotonic()
        key = str(sample.key_expr)
        if key.endswith("/tablet_vel"):
            _record("cb", sample.payload.to_bytes(), t0, t1)

    link_cls._on_sample = traced_on_sample  # type: ignore[method-assign]
    take = link_cls._take

    def traced_take(self: Any, motion: Any) -> Any:
        if motion is True:
            _boost()
        t0 = time.monotonic()
        taken = take(self, motion)
        for key_expr, payload in taken:
            if key_expr.endswith("/tablet_vel"):
                _record("picked", payload, t0, t0)
        return taken

    link_cls._take = traced_take  # type: ignore[method-assign]
    publish = link_cls.publish

    def traced_publish(self: Any, topic: Any, message: Any) -> None:
        t0 = time.monotonic()
        publish(self, topic, message)
        if topic == "mux":
            _record("mux_put", message.angular, t0, time.monotonic())

    link_cls.publish = traced_publish  # type: ignore[method-assign]
    _span(daemon_mod.Daemon, "_pass", "pass")
    _span(daemon_mod.Daemon, "apply_motion", "apply_motion")
    _span(daemon_mod.Daemon, "publish", "publish")
    _span(stack_mod.RobotStack, "step", "step")
    _span(sim_mod.Simulator, "step", "sim_step")
    _span(sim_mod.Simulator, "scan", "sim_scan")
    _span(loc_mod.Localiser, "on_scan", "localise")
    _span(nav_mod.Navigator, "update", "navigate")
    _probe()
    _boost_zenoh_threads()

    def dump() -> None:
        events = [
            (n, _twist_key(k) if isinstance(k, bytes) else k, t0, t1, th)
            for n, k, t0, t1, th in EVENTS
        ]
        out.write_text(json.dumps(events), encoding="utf-8")
        out.with_suffix(".tids.json").write_text(json.dumps({"pid": os.getpid(), **TIDS}))

    atexit.register(dump)


def install_station(out: Path) -> None:
    _switch_interval("station")
    from interbot_core.topics import Topic
    from interbot_link import station as station_mod
    from interbot_qt import qt_tcp_connection as conn_mod

    conn_cls = conn_mod.QtTcpConnection
    ready = conn_cls._on_ready_read

    def traced_ready(self: Any) -> None:
        _boost()
        t0 = time.monotonic()
        ready(self)
        _record("readable", None, t0, time.monotonic())

    conn_cls._on_ready_read = traced_ready  # type: ignore[method-assign]
    send = station_mod.StationLink.send

    def traced_send(self: Any, topic: Any, message: Any) -> bool:
        t0 = time.monotonic()
        ok = send(self, topic, message)
        if topic == Topic.TABLET_VEL:
            _record("put", float(message.angular), t0, time.monotonic())
        return ok

    station_mod.StationLink.send = traced_send  # type: ignore[method-assign]
    from base_station_app import station_controller as sc

    _span(sc.StationController, "_on_frame_timer", "frame_timer")
    _span(sc.StationController, "tick", "tick")
    from base_station_app import qt_map_view

    _span(qt_map_view.QtMapView, "paintEvent", "paint")
    _probe()
    _boost_zenoh_threads()
    atexit.register(_dump, out)


if __name__ == "__main__":
    role = sys.argv[1]
    if role == "daemon":
        install_daemon(Path(os.environ["TELEOP_TRACE"]) / "daemon.json")
        sys.argv = ["robot_daemon.main", *sys.argv[2:]]
        runpy.run_module("robot_daemon.main", run_name="__main__", alter_sys=True)


HOPS = (
    ("tcp", "write", "readable"),
    ("read", "readable", "decoded"),
    ("to_put", "decoded", "put0"),
    ("put", "put0", "put1"),
    ("zenoh_in", "put1", "cb0"),
    ("take", "cb0", "picked"),
    ("mux", "picked", "mux0"),
    ("mux_put", "mux0", "mux1"),
    ("zenoh_out", "mux1", "observed"),
)


def report(trace: Path, worst_fraction: float = 0.03) -> None:
    """Print every hop's p50 / p99 and, for the slowest samples, each hop and what the
    daemon's and the station's threads were doing meanwhile."""
    import numpy as np

    samples = json.loads((trace / "samples.json").read_text())
    daemon = json.loads((trace / "daemon.json").read_text())
    station = json.loads((trace / "station.json").read_text())
    stamps: dict[float, dict[str, float]] = {}
    for _, ang, t in samples["result"]["written"]:
        stamps[ang] = {"write": t}
    for _, ang, t in samples["result"]["observed"]:
        stamps[ang]["observed"] = t
    for _, ang, t in samples["arrived"]:
        stamps[ang]["decoded"] = t
    readable = sorted((t0, t1) for n, k, t0, t1, th in station if n == "readable")
    for s in stamps.values():
        d = s.get("decoded")
        if d is not None:
            inside = [t0 for t0, t1 in readable if t0 <= d <= t1]
            if inside:
                s["readable"] = inside[-1]
    for n, k, t0, t1, _ in station:
        if n == "put" and k in stamps:
            stamps[k].setdefault("put0", t0)
            stamps[k].setdefault("put1", t1)
    for n, k, t0, t1, _ in daemon:
        if k in stamps:
            s = stamps[k]
            if n == "cb":
                s.setdefault("cb0", t0)
                s.setdefault("cb1", t1)
            elif n == "picked":
                s.setdefault("picked", t0)
            elif n == "mux_put":
                s.setdefault("mux0", t0)
                s.setdefault("mux1", t1)
    full = [s for s in stamps.values() if all(h in s for _, a, b in HOPS for h in (a, b))]
    print(f"{len(full)} of {len(stamps)} samples with every stamp")
    total = np.array([s["observed"] - s["write"] for s in full]) * 1e3
    print(f"{'total':10s} p50 {np.percentile(total, 50):6.2f}  p99 {np.percentile(total, 99):6.2f}  max {total.max():6.2f} ms")  # fmt: skip
    for name, a, b in HOPS:
        v = np.array([s[b] - s[a] for s in full]) * 1e3
        print(f"{name:10s} p50 {np.percentile(v, 50):6.2f}  p99 {np.percentile(v, 99):6.2f}  max {v.max():6.2f} ms")  # fmt: skip
    worst = sorted(full, key=lambda s: s["observed"] - s["write"])[-max(1, round(len(full) * worst_fraction)) :]  # fmt: skip
    for s in worst:
        hops = " ".join(f"{name}={1e3 * (s[b] - s[a]):.2f}" for name, a, b in HOPS)
        print(f"\nsample total {1e3 * (s['observed'] - s['write']):.2f} ms: {hops}")
        lo, hi = s["write"] - 0.002, s["observed"]
        for role, events in (("daemon", daemon), ("station", station)):
            for n, _, t0, t1, th in events:
                if (
                    t1 >= lo
                    and t0 <= hi
                    and n not in ("cb", "picked", "mux_put", "put", "readable")
                ):
                    print(f"   {role:7s} {th:18s} {n:13s} {1e3 * (t0 - s['write']):7.2f} .. {1e3 * (t1 - s['write']):7.2f} ms")  # fmt: skip


if __name__ == "__main__" and sys.argv[1] == "report":
    report(Path(sys.argv[2]))
