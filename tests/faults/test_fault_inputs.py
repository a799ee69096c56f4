"""Issue 11 faults: a frozen tablet, a stalled link's backlog, a flood, hostile parameters.

One daemon process serves the module (each test has its own station and tablet):

* **tablet SIGSTOP** - the tablet process turning the robot at 0.3 rad/s is frozen: the
  station's single-shot watchdog sends one zero one ceiling after the last command (median
  within ceiling + 20 ms on the station's own stamps), and the robot's multiplexer output drops
  to zero (figure: last command -> zero on the robot's ``mux`` stamps). ``FAULT_STALLS=50`` for the
  worst of 50 (default 5);
* **backlog after a stall** - 1 s of stamped commands arrives at once, 1 s late: none is
  forwarded;
* **flood** - a client writes speed commands as fast as TCP takes them; the operator's
  EMERGENCY STOP (posted to the station's event loop) reaches the robot's mux within twice
  the time it takes without the flood plus 100 ms (medians of paired clicks, same load);
* **hostile config** - each parameter message that used to crash, freeze or slow the robot is
  refused with a reason naming the field, and the robot keeps running;
* **bad files at start** - a topological map with a dangling arc and a PGM longer than its
  header are refused by the daemon (exit status 2) naming the file and the reason.

Figures are printed (``pytest tests/faults -s``) as ``FAULT <figure>: <value>``.
"""

from __future__ import annotations

import itertools
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from PySide6.QtCore import QTimer

from base_station_app.station_config import StationConfig
from interbot_core.topics import ConfigMsg, Topic, Twist
from tests.faults.conftest import REPO, DaemonProcess, Observer

# "thread": once, under a load of 15-20, a test here hung in C (a futex) where the default
# "signal" timeout cannot interrupt it and the run stalled for good; the thread method dumps
# every thread's stack and ends the run, so CI fails with a reason instead of hanging.
pytestmark = [pytest.mark.slow, pytest.mark.timeout(240, method="thread")]

ROBOT = "inputbot"
CEILING = float(os.environ.get("FAULT_CEILING", "0.3"))  # [s] the station's latency ceiling
STALLS = int(os.environ.get("FAULT_STALLS", "5"))
FLOOD_TRIALS = int(os.environ.get("FAULT_FLOOD_TRIALS", "5"))


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[DaemonProcess]:
    d = DaemonProcess(ROBOT, tmp_path_factory.mktemp("inputs"))
    d.start()
    try:
        yield d
    finally:
        d.close()


@pytest.fixture(scope="module")
def observer(daemon: DaemonProcess) -> Iterator[Observer]:
    obs = Observer([daemon.endpoint])
    try:
        yield obs
    finally:
        obs.close()


def _lines(proc: subprocess.Popen[str]) -> queue.SimpleQueue[str]:
    """The process's output lines, read on a thread (the Qt event loop must keep running)."""
    lines: queue.SimpleQueue[str] = queue.SimpleQueue()

    def pump() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.put(line.strip())

    threading.Thread(target=pump, daemon=True).start()
    return lines


def _record_sends(station) -> list[tuple[float, Topic, object]]:
    """Wrap the station's `_send` to keep what it sent to the robot, with its own clock."""
    sent: list[tuple[float, Topic, object]] = []
    original = station._send

    def send(topic: Topic, message: object) -> bool:
        sent.append((station.clock(), topic, message))
        return original(topic, message)

    station._send = send
    return sent


def test_frozen_tablet_stops_the_robot_within_the_ceiling(rig, daemon, observer) -> None:
    station = rig.station(daemon, robot=ROBOT, config=StationConfig(latency_ceiling=CEILING))
    rig.online(station, ROBOT)
    sent = _record_sends(station)
    tablet = rig.tablet(station, "speed")
    station_delays, robot_delays = [], []
    resumed = time.monotonic()
    for _ in range(STALLS):
        rig.wait(
            lambda resumed=resumed: (
                sum(
                    1
                    for t, topic, m in sent
                    if t > resumed and topic is Topic.TABLET_VEL and m.angular
                )
                >= 3
            ),
            10.0,
            "the tablet to drive again",
        )
        # The observer must see the robot turning before the freeze: a zero it sees first is
        # then the robot's answer to the freeze, not the first message of a late-joining
        # observer (its zenoh session may connect a second after the daemon starts listening).
        rig.wait(
            lambda resumed=resumed: any(
                s.message.angular for s in observer.of(Topic.MUX, ROBOT, since=resumed)
            ),
            10.0,
            "the observer to see the robot turning",
        )
        tablet.send_signal(signal.SIGSTOP)
        frozen = time.monotonic()

        def station_zero(frozen: float = frozen) -> tuple[float, float] | None:
            """(last command forwarded before the freeze, the zero that followed it)."""
            vel = [(t, m) for t, topic, m in sent if topic is Topic.TABLET_VEL]
            last = max((t for t, m in vel if t < frozen and m.angular), default=None)
            zero = next(
                (t for t, m in vel if last is not None and t > last and not m.angular), None
            )
            return None if last is None or zero is None else (last, zero)

        rig.wait(lambda: station_zero() is not None, 5.0, "the station's zero")
        last_cmd, zero_at = station_zero()  # type: ignore[misc]
        station_delays.append(zero_at - last_cmd)

        # The robot's own stamps (its time runs with the wall clock, --speed 1), mapped to the
        # wall by the fastest delivery seen: late callbacks of the observer cannot skew it.
        def robot_zero(last_cmd: float = last_cmd) -> float | None:
            mux = observer.of(Topic.MUX, ROBOT)
            if not mux:
                return None
            offset = min(s.t - s.message.stamp for s in mux)
            zeros = [
                s.message.stamp + offset
                for s in mux
                if (s.message.linear, s.message.angular) == (0.0, 0.0)
                and s.message.stamp + offset > last_cmd
            ]
            return min(zeros, default=None)

        rig.wait(lambda: robot_zero() is not None, 5.0, "the robot's mux output to be zero")
        robot_delays.append(robot_zero() - last_cmd)  # type: ignore[operator]
        tablet.send_signal(signal.SIGCONT)
        resumed = time.monotonic()
    station_delays.sort()
    robot_delays.sort()
    median = STALLS // 2
    print(
        f"\nFAULT frozen tablet, last command -> station zero ({STALLS} stalls, ceiling "
        f"{CEILING * 1000:.0f} ms): median {station_delays[median] * 1000:.1f} ms, worst "
        f"{station_delays[-1] * 1000:.1f} ms"
        f"\nFAULT frozen tablet, last command -> robot mux zero ({STALLS} stalls): median "
        f"{robot_delays[median] * 1000:.1f} ms, worst {robot_delays[-1] * 1000:.1f} ms"
    )
    # The single-shot timer fires at the ceiling (the polled clock() of old fired up to a whole
    # 100 ms period late, and re-stamped the command for as long as it ran). Asserted on the
    # median: on a machine loaded 7x (this one) a timer is sometimes tens of ms late, which is
    # the scheduler's, not the design's (worst of 50 here: +237 ms at load 15 on 2 cores); the
    # worst case is bounded too (the old re-stamping drove on for 10 s at the top ceiling).
    assert station_delays[median] <= CEILING + 0.020
    assert station_delays[-1] <= CEILING + 0.500
    # The robot: one zenoh hop and the daemon's wake-up more, or, when the ceiling is not below
    # the multiplexer's 0.5 s tablet timeout, that timeout and one 20 ms loop pass.
    bound = min(CEILING, 0.5) + 0.020
    assert robot_delays[median] <= bound + 0.010
    assert robot_delays[-1] <= bound + 0.500


def test_backlog_after_a_stalled_link_is_not_forwarded(rig, daemon, observer) -> None:
    station = rig.station(daemon, robot=ROBOT, config=StationConfig(latency_ceiling=CEILING))
    rig.online(station, ROBOT)
    sent = _record_sends(station)
    lines = _lines(rig.tablet(station, "stall"))
    rig.wait(lambda: not lines.empty(), 15.0, "the tablet's backlog")
    assert lines.get() == "burst"  # 1 s of commands, 1 s late, at once
    burst = time.monotonic()
    rig.qtbot.wait(500)
    forwarded = [
        m for t, topic, m in sent if topic is Topic.TABLET_VEL and t >= burst - 0.05 and m.angular
    ]
    print(
        f"\nFAULT stale speed commands forwarded after a stall (10 in the backlog): {len(forwarded)} "
        f"(dropped as stale: {station.arbiter.freshness.dropped_stale})"
    )
    assert forwarded == []
    assert station.arbiter.freshness.dropped_stale >= 1


def _click_to_robot_stop(rig, station, observer) -> tuple[float, float]:
    """Post the EMERGENCY STOP click to the station's event loop (as the button's clicked()
    is queued), then (click -> handled, click -> robot mux stopped) [s], the latter on the
    robot's own stamps mapped to the wall (observer callbacks may lag under load)."""
    handled: list[float] = []
    posted = time.monotonic()
    QTimer.singleShot(
        0, station, lambda: (handled.append(time.monotonic()), station.emergency_stop())
    )

    def stopped_at() -> float | None:
        mux = observer.of(Topic.MUX, ROBOT)
        if not mux:
            return None
        offset = min(s.t - s.message.stamp for s in mux)
        times = [
            s.message.stamp + offset
            for s in mux
            if "Emergency Stop" in s.message.active_locks and s.message.stamp + offset >= posted
        ]
        return min(times, default=None)

    rig.wait(lambda: stopped_at() is not None, 10.0, "the stop at the robot")
    return handled[0] - posted, stopped_at() - posted  # type: ignore[operator]


def test_flood_does_not_delay_the_emergency_stop(rig, daemon, observer) -> None:
    """The operator's stop is not queued behind a client flooding the tablet port.

    What is compared is the same path with and without the flood, under the same load: the
    flooding process is frozen (SIGSTOP) for each baseline click and thawed for each flood
    click, ``FLOOD_TRIALS`` pairs, and the medians are compared. The flood may cost the
    station some CPU (it parses every message), so the bound is twice the baseline plus
    100 ms; a stop that waited for the flood to end, or behind its backlog (seconds), fails.
    One click against one baseline click failed on a machine loaded 6-9x on 2 cores (218 ms
    against 17 ms): both single figures are mostly the scheduler's there.
    """
    station = rig.station(daemon, robot=ROBOT)
    rig.online(station, ROBOT)
    flood = rig.tablet(station, "flood")
    started = time.monotonic()
    ticks: list[float] = []
    station.clocked.connect(lambda: ticks.append(time.monotonic()))
    rig.qtbot.wait(1500)  # flooding
    policy = station.tablet.policy
    elapsed = time.monotonic() - started
    rate = (policy.dropped + policy.config.rate * elapsed) / elapsed
    dropped_in_flood = policy.dropped
    gaps = [b - a for a, b in itertools.pairwise(ticks)]

    def click_and_release() -> tuple[float, float]:
        handled, effective = _click_to_robot_stop(rig, station, observer)
        station.release_stop()
        rig.wait(lambda: not observer.last(Topic.MUX, ROBOT).active_locks, 5.0, "the release")
        return handled, effective

    baseline: list[tuple[float, float]] = []
    flooded: list[tuple[float, float]] = []
    for _ in range(FLOOD_TRIALS):
        flood.send_signal(signal.SIGSTOP)
        rig.qtbot.wait(200)  # the station drains what the socket held
        baseline.append(click_and_release())
        flood.send_signal(signal.SIGCONT)
        rig.qtbot.wait(300)  # flooding again
        flooded.append(click_and_release())
    median = FLOOD_TRIALS // 2
    base_handled, base_effective = (sorted(x)[median] for x in zip(*baseline, strict=True))
    flood_handled, flood_effective = (sorted(x)[median] for x in zip(*flooded, strict=True))
    print(
        f"\nFAULT e-stop click -> robot mux stopped while a client floods (median of "
        f"{FLOOD_TRIALS}): {flood_effective * 1000:.1f} ms (click handled after "
        f"{flood_handled * 1000:.1f} ms; without the flood {base_effective * 1000:.1f} ms, "
        f"handled after {base_handled * 1000:.1f} ms; the station consumed "
        f"~{rate / 1000:.0f} k msg/s, the writer held back by TCP; clock() ran {len(ticks)} "
        f"times in 1.5 s, longest gap {max(gaps) * 1000:.0f} ms)"
    )
    assert flood_effective <= 2 * base_effective + 0.100
    assert flood_handled <= 2 * base_handled + 0.100
    assert dropped_in_flood > 1000  # it was a flood, and it was bounded


HOSTILE = [
    ({"local_grid_resolution": 1e-6}, "local_grid_resolution"),  # tried to allocate 6.95 TiB
    ({"v_samples": 101, "w_samples": 201}, "v_samples"),  # froze the loop for 11.8 s
    ({"sim_time": 10.0, "sim_dt": 0.001}, "sim_"),  # froze the loop
    ({"sim_dt": 1e-4}, "sim_dt"),  # made the e-stop take 1.1 s
    ({"max_linear_speed": 4.9}, "max_linear_speed"),
    ({"inflation_radius": 1e9}, "inflation_radius"),
    ({"no_such_parameter": 1}, "no_such_parameter"),
]


def test_hostile_config_messages_are_refused_with_a_reason(rig, daemon, observer) -> None:
    station = rig.station(daemon, robot=ROBOT)
    rig.online(station, ROBOT)
    for params, field in HOSTILE:
        since = time.monotonic()
        assert station._send(Topic.CONFIG, ConfigMsg(params))
        rig.wait(
            lambda field=field, since=since: bool(
                observer.robot_said(ROBOT, f"refused config: .*{field}", since)
            ),
            10.0,
            f"the robot to refuse {params}",
        )
    refused = len(HOSTILE)
    # A duplicate key on zenoh ({"linear": 0.1, ..., "linear": 0.45}) is dropped, as on TCP.
    before = time.monotonic()
    publisher = station.link._followed.publishers[Topic.STATION_VEL]
    for _ in range(5):
        publisher.put(b'{"linear":0.1,"angular":0.0,"stamp":0,"linear":0.45}')
        rig.qtbot.wait(20)
    # The robot is alive, its loop runs at its rate and it obeys a normal command at once.
    station._send(Topic.STATION_VEL, Twist(0.0, 0.2, stamp=station.clock()))
    rig.wait(
        lambda: any(
            s.message.source == "Base Station" for s in observer.of(Topic.MUX, ROBOT, before)
        ),
        5.0,
        "a normal command to drive",
    )
    # (Select by source: arrival times of another test's messages can lag under load.)
    duplicates = [
        s.message
        for s in observer.of(Topic.MUX, ROBOT, before)
        if s.message.source == "Base Station" and s.message.linear
    ]
    assert duplicates == []
    assert daemon.proc is not None and daemon.proc.poll() is None
    rig.qtbot.wait(500)
    stamps = [s.message.stamp for s in observer.of(Topic.POSE, ROBOT, before)]
    assert len(stamps) >= 5 and max(b - a for a, b in itertools.pairwise(stamps)) < 0.5
    print(f"\nFAULT hostile config messages accepted: 0 of {refused} (each refused with a reason)")


def _daemon_refuses(tmp: Path, *args: str) -> str:
    cmd = [sys.executable, "-m", "robot_daemon.main", "--sim", "--listen", "tcp/127.0.0.1:0"]
    proc = subprocess.run(
        cmd + list(args), capture_output=True, text=True, timeout=60, cwd=REPO, check=False
    )
    assert proc.returncode == 2, proc.stdout + proc.stderr
    return proc.stderr


def test_bad_map_files_are_refused_at_start(tmp_path: Path) -> None:
    topo = tmp_path / "topo.yaml"
    original = (REPO / "maps" / "isr_floor0_topo.yaml").read_text()
    topo.write_text(original.replace("map:", f"map: {REPO / 'maps'}/", 1) + "\n", "utf-8")
    import yaml

    data = yaml.safe_load(original)
    data["map"] = str(REPO / "maps" / "isr_floor0.yaml")
    data["arcs"].append([0, 999])
    topo.write_text(yaml.safe_dump(data), "utf-8")
    error = _daemon_refuses(tmp_path, "--topo", str(topo))
    assert str(topo) in error and "999" in error
    pgm = tmp_path / "m.pgm"
    pgm.write_bytes(b"P5\n10 10\n255\n" + bytes(150))
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        "utf-8",
    )
    error = _daemon_refuses(tmp_path, "--map", str(tmp_path / "m.yaml"))
    assert "m.pgm" in error and "150 bytes but the header says 10x10" in error
