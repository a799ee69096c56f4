"""Benchmark: what MCAP recording costs the daemon's control loop, and how big a tour's file is.

The data are a real simulated tour (the ISR floor, people walking, the full robot stack driving
the thesis's guided tour) sampled as the issue's target load: the laser at 40 Hz (1081 beams,
UTM-30LX), the camera at 10 Hz (the simulator's 320x240 JPEG, quality 70), pose / odometry /
cmd_vel at 20 Hz, the mux at 5 Hz, the battery at 1 Hz, plus the map, the routes and every
planned path. They are generated first; then the timed part offers them to a `Recorder` (rotating
files, zstd) one second of data at a time, as the daemon's loop would, and waits for the writer:

* ``record_offer_us_*``: one offer on the loop's thread (a non-blocking queue put);
* ``record_loop_pct_core``: the loop's share of a core spent offering (sum of offers / data time);
* ``record_writer_pct_core``: the writer thread's CPU time (conversion to Foxglove schemas,
  protobuf encoding, zstd) per second of data; ``record_total_pct_core`` adds the two
  (target <= 5 %);
* ``record_process_pct_core``: the whole process's CPU time over the timed part (offers, writer,
  the SDK's own threads, the waits between seconds) per second of data: an upper bound;
* ``record_daemon_pass_{off,on}_ms_*``: CPU time of the real daemon's loop pass (stack step +
  publish, the simulator excluded; ``time.thread_time``, so other processes do not count) at 40 Hz scans and a 10 Hz camera, without and with ``--record``; the
  difference is the recording's cost in the loop itself; ``record_daemon_loop_pct_core_{off,on}``
  the loop's CPU per second of robot time, and ``record_daemon_cost_pct_core`` = on - off + the
  writer thread's share (target <= 5 %);
* ``record_mb_per_hour``: bytes on disk per second of data x 3600 (EXTRAPOLATED from the run's
  ``record_data_s`` seconds); ``record_dropped``: messages dropped (must be 0).

    .venv/bin/interbot bench --only record --json
"""

from __future__ import annotations

import importlib.util
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

DATA_S = 60.0  # [s] of tour data
QUICK_DATA_S = 4.0
LOOP_S = 30.0  # [s] of daemon loop passes, with and without recording
QUICK_LOOP_S = 2.0
WARM_UP_S = 0.5  # [s] first passes (caches, the first localisation) left out
SCAN_HZ, CAMERA_HZ, STATE_HZ, MUX_HZ, BATTERY_HZ = 40.0, 10.0, 20.0, 5.0, 1.0


def _tour_data(seconds: float) -> tuple[list[tuple[float, str, Any]], Any]:
    """(t, kind, payload) for ``seconds`` of a guided tour, at the target rates."""
    from interbot_core.supervisor import GuidedTour
    from interbot_core.topics import Battery, ImageMsg, MuxMsg, Odom, PoseMsg, Topic, Twist
    from robot_daemon.planning.path_report import plan_message
    from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem, auto_resume_tour
    from robot_daemon.sim.camera_sim import encode_jpeg
    from robot_daemon.stack import Periodic

    system = SimulatedSystem(ScenarioOptions(seed=2, people=4))
    system.hooks.append(auto_resume_tour(5.0))
    system.localise()
    system.apply(system.supervisor.submit(GuidedTour()))
    due = {n: Periodic(hz) for n, hz in (("scan", SCAN_HZ), ("cam", CAMERA_HZ), ("state", STATE_HZ), ("mux", MUX_HZ), ("bat", BATTERY_HZ))}  # fmt: skip
    items: list[tuple[float, str, Any]] = [(0.0, "state", (Topic.MAP, system.grid))]
    last_path: list[tuple[float, float]] | None = None
    last_route = None
    while system.now < seconds:
        system.step()
        t, stack = system.now, system.stack
        if due["scan"](t):
            items.append((t, "state", (Topic.SCAN, system.sim.scan())))
        if due["cam"](t):
            jpeg = encode_jpeg(system.sim.camera_frame(), 70)
            items.append((t, "state", (Topic.IMAGE, ImageMsg(t, 320, 240, jpeg))))
        if due["state"](t):
            p = stack.pose or system.start_pose
            items.append((t, "state", (Topic.POSE, PoseMsg(p.x, p.y, p.yaw, t, "ok", 0.9))))
            if stack.last_odometry is not None:
                o = stack.last_odometry
                odom = Odom(o.pose.x, o.pose.y, o.pose.yaw, o.linear, o.angular, t)
                items.append((t, "state", (Topic.ODOM, odom)))
            out = stack.last_output
            items.append((t, "state", (Topic.CMD_VEL, Twist(out.linear, out.angular, t))))
            path = stack.navigator.path
            if path != last_path:
                last_path = path
                items.append((t, "state", (Topic.PLAN, plan_message(0, path, t))))
        if due["mux"](t):
            out = stack.last_output
            mux = MuxMsg(out.source, out.reason, out.active_locks, out.linear, out.angular, t)
            items.append((t, "state", (Topic.MUX, mux)))
        if due["bat"](t) and stack.last_battery is not None:
            b = stack.last_battery
            items.append((t, "state", (Topic.BATTERY, Battery(b.voltage, b.current, b.state_of_charge, t))))  # fmt: skip
        if stack.route is not None and stack.route.route_id != last_route:
            last_route = stack.route.route_id
            items.append((t, "json", ("/route_debug", {"route_id": last_route})))
    return items, system


def run(quick: bool = False) -> dict[str, Any]:
    seconds = QUICK_DATA_S if quick else DATA_S
    with common.quiet_logs(), tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp:
        items, _ = _tour_data(seconds)
        figures = _measure(items, seconds, Path(tmp))
        loop_s = QUICK_LOOP_S if quick else LOOP_S
        plain = _daemon_passes(None, loop_s)
        recorded = _daemon_passes(Path(tmp) / "daemon", loop_s)
        figures.update(common.summary_ms(plain, "record_daemon_pass_off"))
        figures.update(common.summary_ms(recorded, "record_daemon_pass_on"))
        measured_s = loop_s - WARM_UP_S
        off_pct = 100.0 * float(plain.sum()) / measured_s
        on_pct = 100.0 * float(recorded.sum()) / measured_s
        figures["record_daemon_loop_pct_core_off"] = off_pct
        figures["record_daemon_loop_pct_core_on"] = on_pct
        # The loop's extra CPU with recording plus the writer thread's: the cost of recording.
        figures["record_daemon_cost_pct_core"] = (
            on_pct - off_pct + figures["record_writer_pct_core"]
        )
        return figures


def _daemon_passes(record_dir: Path | None, seconds: float) -> np.ndarray:
    """CPU time of each daemon loop pass (stack step + publish) on simulated time [s].

    The real daemon (simulator at 40 Hz scans and a 10 Hz camera, localised, standing) on a
    loopback zenoh session with no station; with ``record_dir`` its link is a `RecordingLink`
    (``--record``): the difference of the two is the recording's cost in the loop.
    """
    import socket

    from interbot_link import open_session
    from robot_daemon.config import DaemonConfig, Rates, SimSettings, ZenohSettings
    from robot_daemon.daemon import LOOP_PERIOD, Daemon, DaemonOptions
    from robot_daemon.recording import daemon_hook

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        endpoint = f"tcp/127.0.0.1:{sock.getsockname()[1]}"
    config = DaemonConfig(
        robot_id="benchrec",
        rates=Rates(scan_hz=SCAN_HZ, image_hz=CAMERA_HZ, pose_hz=STATE_HZ),
        sim=SimSettings(seed=1, people=0),
        zenoh=ZenohSettings((endpoint,), ()),
    )
    options = DaemonOptions(auto_localise=True, record_dir=record_dir)
    daemon = Daemon(config, options)
    recorder = daemon_hook.build_daemon_recorder(config, options, 0.0)
    times = []
    with open_session([endpoint], []) as session:
        link = daemon_hook.make_link(session, daemon, recorder)
        try:
            for i in range(1, int(seconds / LOOP_PERIOD) + 1):
                now = daemon.now = i * LOOP_PERIOD
                daemon.backend.advance(now)  # the simulator: not part of the loop's cost
                start = time.thread_time()  # CPU of this thread: other processes' load excluded
                daemon.stack.step(now)
                daemon.publish(link)
                if now > WARM_UP_S:
                    times.append(time.thread_time() - start)
        finally:
            link.close()
            if recorder is not None:
                recorder.close()
    return np.asarray(times)


def _measure(items: list[tuple[float, str, Any]], seconds: float, tmp: Path) -> dict[str, Any]:
    from robot_daemon.config import MB, RecordingConfig
    from robot_daemon.recording.recorder import McapRotation, Recorder

    config = RecordingConfig(directory=str(tmp), max_file_mb=64, max_total_mb=1024)
    recorder = Recorder("bench", rotation=McapRotation(config, "bench"), queue_size=config.queue)
    offers: list[float] = []
    clock = time.perf_counter
    cpu_start = time.process_time()
    second = 1.0
    for t, kind, payload in items:
        if t >= second:  # the writer catches up between two seconds of data, as in real time
            recorder.flush(60.0)
            second += 1.0
        start = clock()
        if kind == "state":
            recorder.state(payload[0], payload[1], t)
        else:
            recorder.json(payload[0], payload[1], t)
        offers.append(clock() - start)
    recorder.close()
    process_pct = 100.0 * (time.process_time() - cpu_start) / seconds
    size = sum(p.stat().st_size for p in tmp.glob("*.mcap"))
    loop_pct = 100.0 * float(np.sum(offers)) / seconds
    writer_pct = 100.0 * recorder.writer_cpu_s / seconds
    us = np.asarray(offers) * 1e6
    return {
        "record_offer_us_median": float(np.median(us)),
        "record_offer_us_p99": float(np.percentile(us, 99)),
        "record_loop_pct_core": loop_pct,
        "record_writer_pct_core": writer_pct,
        "record_total_pct_core": loop_pct + writer_pct,
        # Every thread of the process while recording (includes the flush waits): an upper bound.
        "record_process_pct_core": process_pct,
        "record_mb_per_hour": size / MB / seconds * 3600.0,
        "record_data_s": seconds,
        "record_messages": len(items),
        "record_dropped": recorder.dropped,
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=1))
