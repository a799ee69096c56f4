"""Benchmark: tablet teleoperation latency end to end, and the Base Station's clock() period.

Set-up (all on 127.0.0.1, ports picked by the OS):

* the real simulated robot daemon, ``python -m robot_daemon.main --sim --auto-localise``, in its
  own process as on the robot, with the laser published at the UTM-30LX's 40 Hz and pose / mux
  state published on every 20 ms loop pass (``pose_hz: 100`` >= the loop rate);
* the Base Station in this process: `StationController` with its `MainWindow` shown offscreen
  (``QT_QPA_PLATFORM=offscreen``) and the QApplication event loop in the main thread, so the
  map view redraws the robot's scans at the laser rate while the clock() timer runs;
* a raw TCP socket as the tablet, speaking the thesis's bare JSON ``{"speed": {...}}`` (no
  hello, no newline), and a third zenoh session subscribed to the robot's ``mux`` topic.

Each sample writes a new, distinct speed to the socket (after a random 0-100 ms pause, so the
write falls at a random phase of the station's 100 ms clock) and waits until the mux output the
daemon publishes carries exactly that speed. ``teleop_latency_ms_*`` is write -> mux output.

Why observe the ``mux`` topic rather than ``stack.last_output`` of a daemon thread: in one
process the daemon's work (simulator, 40 Hz ray casting, localiser, planner) would share the GIL
with the station's Qt thread and distort both figures; the real system runs them on different
machines. The daemon publishes the mux output in the same loop pass that computes it, so the
topic adds only one loopback zenoh hop (~0.2 ms, FIELD_NOTES) to the moment it changed.

The station forwards a fresh, permitted tablet speed once, on arrival (never re-stamped; its
single-shot watchdog sends one zero after a ceiling of silence, issue 11); the daemon wakes on a command
and sends the mux output to the motors at once instead of at its next 20 ms pass. The station is
subclassed to timestamp the message's arrival, which splits each sample into ``tcp_to_station``
(socket -> the station's Qt event loop) + ``station_to_mux`` (station -> zenoh -> daemon -> mux
-> zenoh back). ``clock_period_ms_*`` is the station's own `PeriodStats` of clock() periods
(``controller.clock_periods``) over the sampling, while the view redraws at the scan rate
(``station_scan_view_hz``: distinct scans the frame timer pulled per second).

    .venv/bin/interbot bench --only teleop --json
    .venv/bin/interbot bench --only teleop --secure --json   # issue 15: TLS everywhere
    .venv/bin/interbot bench --only teleop --busy-core --json  # issue 14: one core kept busy

With ``--busy-core`` (figures ``teleop_busy_*``) another process spins on one core for the whole
measurement (``python -c "while True: pass"``), as on an operator's laptop running something
else. ``TELEOP_SAMPLES=N`` changes the number of samples (300; ``--quick`` 20).

The simulated world has no people (``people: 0``): the command turns the robot on the spot, and
a person walking by put the collision monitor's slowdown on the mux output, which then never
carried the exact speed (259 of 300 samples "missed" in one run): that measured the monitor,
not the command path. A missed sample is reported with what the mux said instead
(``teleop_miss_reasons``), never silently.

With ``--secure`` (figures named ``teleop_tls_*``) every link is the secured one of issue 15:
zenoh over mutual TLS with access control (keys made in a temporary directory), and the tablet
socket is TLS to the station's `TabletAuthServer`, pinned on its certificate and authenticated
with a paired token before the first speed message.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import socket
import ssl
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

ROBOT = "benchbot"
SAMPLES = int(os.environ.get("TELEOP_SAMPLES", "300"))
QUICK_SAMPLES = 20
SAMPLE_TIMEOUT_S = 2.0  # a speed not seen at the mux by then counts as missed
STARTUP_TIMEOUT_S = 40.0
SEED = 1
DAEMON_YAML = """\
robot_id: {robot}
rates: {{pose_hz: 100, scan_hz: 40}}
sim: {{seed: 1, people: 0}}
"""


class BenchTeleopError(RuntimeError):
    """The teleoperation rig did not come up (the message says which part)."""


def free_loopback_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def speed_value(i: int) -> tuple[float, float]:
    """The ``i``-th distinct command: turn on the spot, alternating direction, growing rate.

    (linear 0 keeps the robot where it is; each value differs from every other one.)
    """
    return 0.0, round((-1.0) ** i * (0.1 + 0.002 * i), 6)


def run(quick: bool = False, secure: bool = False, busy_core: bool = False) -> dict[str, Any]:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    with (
        common.quiet_logs(),
        tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp,
        busy_process(busy_core),
    ):
        out = _run(Path(tmp), QUICK_SAMPLES if quick else SAMPLES, secure)
    prefix = "teleop_" + ("tls_" if secure else "") + ("busy_" if busy_core else "")
    return {k.replace("teleop_", prefix, 1): v for k, v in out.items()}


@contextlib.contextmanager
def busy_process(enabled: bool) -> Iterator[subprocess.Popen[bytes] | None]:
    """With ``enabled``: one other process spinning on a core for the whole measurement.

    (``--busy-core``: the station and the daemon share the remaining CPU with it, as on an
    operator's laptop running something else.)
    """
    if not enabled:
        yield None
        return
    spin = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        yield spin
    finally:
        spin.kill()
        spin.wait()


def _run(tmp: Path, n_samples: int, secure: bool = False) -> dict[str, Any]:
    keys = None
    if secure:
        from interbot_link import KeyStore

        members = ((ROBOT, "robot"), ("station", "station"), ("observer", "observer"))
        keys = KeyStore.init(tmp / "keys", members).dir
    endpoint = f"{'tls' if secure else 'tcp'}/127.0.0.1:{free_loopback_port()}"
    config = tmp / "robot.yaml"
    config.write_text(DAEMON_YAML.format(robot=ROBOT), encoding="utf-8")
    log_path = tmp / "daemon.log"
    cmd = [sys.executable, "-m", "robot_daemon.main", "--sim", "--config", str(config)]
    cmd += ["--robot-id", ROBOT, "--listen", endpoint, "--auto-localise"]
    if keys is not None:
        cmd += ["--security", str(keys)]
    t_launch = time.perf_counter()
    with log_path.open("w") as log:
        proc = subprocess.Popen(cmd, cwd=common.REPO, stdout=subprocess.DEVNULL, stderr=log)
    try:
        return _measure(tmp, n_samples, proc, endpoint, log_path, t_launch, keys)
    finally:
        if proc.poll() is None:
            proc.terminate()  # SIGTERM: the daemon stops its motors and closes its session
            try:
                proc.wait(15.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def _paired_tablet_auth(keys: Path) -> tuple[Any, str]:
    """The station's TLS tablet server with one tablet paired; (server, token)."""
    import secrets

    from base_station_app.tablet_auth import TabletAuthServer
    from interbot_core.tablet_pairing import TabletRegistry

    registry = TabletRegistry(secrets.token_bytes)
    code, _ = registry.new_code(time.time())
    _, token = registry.pair(code, "bench tablet", time.time())
    cert, key = (keys / "station.crt").read_bytes(), (keys / "station.key").read_bytes()
    return TabletAuthServer(cert, key, registry, time.time), token


def _tls_tablet(
    raw: socket.socket, fingerprint: str, token: str, wait_until: Callable[..., None]
) -> socket.socket:
    """TLS over ``raw``, pinned on ``fingerprint``, authenticated with ``token`` (as the tablet).

    The handshake runs in a thread while the Qt loop (the station) runs in this one.
    """
    import hashlib

    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    context.check_hostname = False
    context.verify_mode = ssl.CERT_NONE  # pinned below, as tablet_app.pairing does
    result: list[Any] = []

    def handshake() -> None:
        try:
            tls = context.wrap_socket(raw, server_hostname="station")
            der = tls.getpeercert(binary_form=True) or b""
            if hashlib.sha256(der).hexdigest() != fingerprint:
                raise BenchTeleopError("bench_teleop: the station's certificate is not pinned one")
            tls.sendall(json.dumps({"auth": {"token": token}}).encode() + b"\n")
            reply = b""
            while b"\n" not in reply:
                chunk = tls.recv(4096)
                if not chunk:
                    raise BenchTeleopError("bench_teleop: the station closed the TLS tablet")
                reply += chunk
            if b"authorised" not in reply:
                raise BenchTeleopError(f"bench_teleop: tablet not authorised: {reply!r}")
            result.append(tls)
        except BaseException as exc:  # raised again in the caller's thread
            result.append(exc)

    thread = threading.Thread(target=handshake, daemon=True)
    thread.start()
    wait_until(lambda: bool(result), 10.0, "the TLS tablet handshake")
    thread.join()
    if isinstance(result[0], BaseException):
        raise result[0]
    tls_socket: socket.socket = result[0]
    return tls_socket


def wait_for_daemon(proc: subprocess.Popen[bytes], log_path: Path, timeout_s: float) -> None:
    """Block until the daemon logs "daemon ready" (its zenoh endpoint is listening)."""
    deadline = time.perf_counter() + timeout_s
    while "daemon ready" not in log_path.read_text(encoding="utf-8"):
        if proc.poll() is not None:
            raise BenchTeleopError(
                f"bench_teleop: the daemon exited with {proc.returncode}: "
                f"{log_path.read_text(encoding='utf-8')[-2000:]}"
            )
        if time.perf_counter() > deadline:
            raise BenchTeleopError(f"bench_teleop: the daemon was not ready in {timeout_s:.0f} s")
        time.sleep(0.02)


def _measure(
    tmp: Path,
    n_samples: int,
    proc: subprocess.Popen[bytes],
    endpoint: str,
    log_path: Path,
    t_launch: float,
    keys: Path | None = None,
) -> dict[str, Any]:
    # Qt and zenoh are imported here so that importing the module stays cheap.
    import zenoh
    from PySide6.QtCore import QEventLoop, QObject, QSettings, QTimer, Signal
    from PySide6.QtWidgets import QApplication

    from base_station_app.main_window import MainWindow
    from base_station_app.station_controller import StationController
    from interbot_core import protocol as p
    from interbot_core.topics import MuxMsg, Topic, decode, key
    from interbot_core.topological_map import load_topological_map
    from interbot_link import LinkSecurity, session_config

    class TimedStation(StationController):
        """The station, timestamping the arrival of each tablet speed message."""

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.arrived: dict[tuple[float, float], float] = {}

        def on_tablet_message(self, msg: object) -> None:
            if isinstance(msg, p.Speed):
                self.arrived.setdefault((msg.linear, msg.angular), time.perf_counter())
            super().on_tablet_message(msg)

    class MuxObserver(QObject):
        """Timestamps every ``mux`` sample on the zenoh thread; the Qt thread decodes them."""

        arrived = Signal()

        def __init__(self) -> None:
            super().__init__()
            self.samples: deque[tuple[float, bytes]] = deque()
            self.lock = threading.Lock()

        def on_sample(self, sample: zenoh.Sample) -> None:  # zenoh thread: keep it trivial
            stamp = time.perf_counter()
            with self.lock:
                self.samples.append((stamp, sample.payload.to_bytes()))
            self.arrived.emit()

        def drain(self) -> list[tuple[float, MuxMsg]]:
            with self.lock:
                raw, self.samples = list(self.samples), deque()
            out = []
            for stamp, payload in raw:
                msg = decode(Topic.MUX, payload)
                if isinstance(msg, MuxMsg):
                    out.append((stamp, msg))
            return out

    app = QApplication.instance() or QApplication([sys.argv[0]])
    loop = QEventLoop()

    def wait_until(done: Callable[[], bool], timeout_s: float, what: str) -> None:
        """Run the Qt event loop until ``done()`` (checked every 10 ms) or fail naming ``what``."""
        deadline = time.perf_counter() + timeout_s
        failure: list[BaseException] = []

        def check() -> None:
            try:
                if done() or time.perf_counter() > deadline:
                    loop.quit()
            except BaseException as exc:  # raised again below, outside the Qt slot
                failure.append(exc)
                loop.quit()

        poll = QTimer()
        poll.setInterval(10)
        poll.timeout.connect(check)
        poll.start()
        if not done():
            loop.exec()
        poll.stop()
        if failure:
            raise failure[0]
        if not done():
            raise BenchTeleopError(f"bench_teleop: timed out after {timeout_s:.0f} s waiting for {what}")  # fmt: skip

    station_session = observer_session = None
    controller: TimedStation | None = None
    window = None
    tablet: socket.socket | None = None
    subscriber = None
    try:
        topo = load_topological_map(common.ISR_TOPO)
        wait_for_daemon(proc, log_path, STARTUP_TIMEOUT_S)
        tablet_auth = None
        if keys is None:
            station_session = zenoh.open(session_config([], [endpoint]))
            observer_session = zenoh.open(session_config([], [endpoint]))
        else:
            station_sec = LinkSecurity.load(keys, "station", "station")
            observer_sec = LinkSecurity.load(keys, "observer", "observer")
            station_session = zenoh.open(session_config([], [endpoint], security=station_sec))
            observer_session = zenoh.open(session_config([], [endpoint], security=observer_sec))
            tablet_auth, token = _paired_tablet_auth(keys)
        observer = MuxObserver()
        subscriber = observer_session.declare_subscriber(key(ROBOT, Topic.MUX), observer.on_sample)
        controller = TimedStation(
            topo,
            station_session,
            topo_path=common.ISR_TOPO,
            tablet_port=0,
            robot_id=ROBOT,
            tablet_auth=tablet_auth,
        )
        settings = QSettings(str(tmp / "station.ini"), QSettings.Format.IniFormat)
        window = MainWindow(controller, settings)
        if not controller.start():
            raise BenchTeleopError("bench_teleop: the station cannot listen for the tablet")
        window.resize(1600, 1000)
        window.show()
        scans_seen: list[object] = [None]
        scan_count = [0]

        def on_frame() -> None:
            scan = controller.selected.state.scan if controller is not None else None
            if scan is not None and scan is not scans_seen[0]:
                scans_seen[0] = scan
                scan_count[0] += 1

        controller.frame_ready.connect(on_frame)

        def robot_ready() -> bool:
            if proc.poll() is not None:
                raise BenchTeleopError(
                    f"bench_teleop: the daemon exited with {proc.returncode}: "
                    f"{log_path.read_text(encoding='utf-8')[-2000:]}"
                )
            state = controller.selected.state
            return (
                controller.selected_robot == ROBOT
                and state.grid is not None
                and state.scan is not None
                and state.localisation == "ok"
                and bool(observer.samples)
            )

        wait_until(robot_ready, STARTUP_TIMEOUT_S, "the simulated robot (pose, map, scan, mux)")
        startup = time.perf_counter() - t_launch
        window.map_view.fit_map()
        tablet = socket.create_connection(("127.0.0.1", controller.tablet.port), timeout=2.0)
        tablet.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if tablet_auth is not None:
            tablet = _tls_tablet(tablet, tablet_auth.fingerprint, token, wait_until)
        tablet.setblocking(False)
        wait_until(lambda: controller.tablet.is_connected, 5.0, "the tablet connection")

        rng = np.random.default_rng(SEED)
        written: dict[tuple[float, float], float] = {}
        observed: dict[tuple[float, float], float] = {}
        missed = [0]
        seen_mux: set[str] = set()  # what the mux output during the current sample
        miss_reasons: dict[str, int] = {}
        state = {"i": 0, "expected": None, "t_write": 0.0}
        send_timer = QTimer()
        send_timer.setSingleShot(True)
        miss_timer = QTimer()
        miss_timer.setSingleShot(True)

        def drain_tablet() -> None:
            assert tablet is not None
            while True:
                try:
                    if not tablet.recv(65536):
                        raise BenchTeleopError("bench_teleop: the station closed the tablet")
                except (BlockingIOError, ssl.SSLWantReadError):  # nothing more (plain / TLS)
                    return

        def next_sample() -> None:
            state["expected"] = None
            seen_mux.clear()
            if state["i"] >= n_samples:
                loop.quit()
                return
            send_timer.start(int(rng.integers(0, 101)))  # random phase against clock()

        def send() -> None:
            assert tablet is not None
            drain_tablet()
            value = speed_value(state["i"])
            state["i"] += 1
            frame = json.dumps({"speed": {"linear": value[0], "angular": value[1]}}).encode()
            state["expected"] = value
            written[value] = time.perf_counter()
            tablet.sendall(frame)
            miss_timer.start(int(SAMPLE_TIMEOUT_S * 1000))

        def on_mux() -> None:
            expected = state["expected"]
            for stamp, msg in observer.drain():
                seen_mux.add(f"{msg.source}/{msg.reason} ({msg.linear:g}, {msg.angular:g})")
                if expected is None:
                    continue
                if abs(msg.linear - expected[0]) < 1e-6 and abs(msg.angular - expected[1]) < 1e-6:
                    observed[expected] = stamp
                    miss_timer.stop()
                    next_sample()
                    return

        def on_miss() -> None:
            missed[0] += 1
            why = " | ".join(sorted(seen_mux)) or "no mux output"
            miss_reasons[why] = miss_reasons.get(why, 0) + 1
            next_sample()

        send_timer.timeout.connect(send)
        miss_timer.timeout.connect(on_miss)
        observer.arrived.connect(on_mux)
        observer.drain()
        controller.clock_periods.clear()
        scan_count[0] = 0
        t0 = time.perf_counter()
        next_sample()
        loop.exec()
        wall = time.perf_counter() - t0
        send_timer.stop()
        miss_timer.stop()
        observer.arrived.disconnect(on_mux)
        clock = controller.clock_periods.summary(threshold=0.11)
    finally:
        if subscriber is not None:
            subscriber.undeclare()
        if tablet is not None:
            tablet.close()
        if window is not None:
            window.close()  # writes its settings to tmp and shuts the controller down
        elif controller is not None:
            controller.shutdown()
        for session in (station_session, observer_session):
            if session is not None:
                session.close()
        app.processEvents()

    total, tcp_in, to_mux = [], [], []
    for value, t_mux in observed.items():
        t_write = written[value]
        total.append(t_mux - t_write)
        t_arrive = controller.arrived.get(value)
        if t_arrive is None:
            continue
        tcp_in.append(t_arrive - t_write)
        to_mux.append(t_mux - t_arrive)
    out: dict[str, Any] = {}
    out.update(common.summary_ms(total, "teleop_latency", median_name="p50"))
    out.update(common.summary_ms(tcp_in, "teleop_tcp_to_station", median_name="p50"))
    out.update(common.summary_ms(to_mux, "teleop_station_to_mux", median_name="p50"))
    out["teleop_samples"] = float(len(total))
    out["teleop_missed"] = float(missed[0])
    if miss_reasons:  # what the robot's mux said instead (e.g. the collision monitor)
        out["teleop_miss_reasons"] = dict(sorted(miss_reasons.items(), key=lambda kv: -kv[1])[:5])
    out["clock_period_ms_p50"] = clock.p50 * 1e3
    out["clock_period_ms_p99"] = clock.p99 * 1e3
    out["clock_period_ms_max"] = clock.maximum * 1e3
    out["clock_periods"] = float(clock.count)
    out["station_scan_view_hz"] = scan_count[0] / wall
    out["teleop_startup_s"] = startup  # daemon launch to robot state in the station's view
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
