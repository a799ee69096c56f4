"""Benchmark: tablet teleoperation latency end to end, and the Base Station's clock() period.

Set-up (all on 127.0.0.1, ports picked by the OS):

* the real simulated robot daemon, ``python -m robot_daemon.main --sim --auto-localise``, in its
  own process as on the robot, with the laser published at the UTM-30LX's 40 Hz and pose / mux
  state published on every 20 ms loop pass (``pose_hz: 100`` >= the loop rate);
* the Base Station in this process: `StationController` with its `MainWindow` shown offscreen
  (``QT_QPA_PLATFORM=offscreen``) and the QApplication event loop in the main thread, so the
  map view redraws the robot's scans at the laser rate while the clock() timer runs;
* the tablet and the observer in a third process (``bench/_teleop_tablet.py``): a raw TCP
  socket as the tablet, speaking the thesis's bare JSON ``{"speed": {...}}`` (no hello, no
  newline), and a zenoh session subscribed to the robot's ``mux`` topic.

Each sample writes a new, distinct speed to the socket (after a random 0-100 ms pause, so the
write falls at a random phase of the station's 100 ms clock) and waits until the mux output the
daemon publishes carries exactly that speed. ``teleop_latency_ms_*`` is write -> mux output.

Why observe the ``mux`` topic rather than ``stack.last_output`` of a daemon thread: in one
process the daemon's work (simulator, 40 Hz ray casting, localiser, planner) would share the GIL
with the station's Qt thread and distort both figures; the real system runs them on different
machines. The daemon publishes the mux output the moment its command thread computed it, so
the topic adds only one loopback zenoh hop (~0.2 ms, FIELD_NOTES) to the moment it changed.

Why the tablet and the observer are not in the station's process (changed in issue 14): there
they shared the GIL and the Qt thread with the station under test, so a frame being drawn
delayed the tablet's write and the observer's time stamp too, and the writes could only
happen when the Qt thread was idle (a phase bias). Each process stamps with
``time.monotonic()`` (CLOCK_MONOTONIC, one clock for the whole machine).

The station forwards a fresh, permitted tablet speed once, on arrival, from its tablet thread
(never re-stamped; its single-shot watchdog sends one zero after a ceiling of silence, issue
11); the daemon's command thread applies it to the multiplexer and the motors at once, whatever
its control loop is doing (issue 14). The station's ``speed_received`` is time stamped in the
tablet thread, which splits each sample into ``tcp_to_station`` (socket -> decoded in the
station's tablet thread) + ``station_to_mux`` (station -> zenoh -> daemon -> mux -> zenoh
back). ``clock_period_ms_*`` is the station's own `PeriodStats` of clock() periods
(``controller.clock_periods``) over the sampling, while the view redraws at the scan rate
(``station_scan_view_hz``: distinct scans the frame timer pulled per second).

    .venv/bin/interbot bench --only teleop --json
    .venv/bin/interbot bench --only teleop --secure --json   # issue 15: TLS everywhere
    .venv/bin/interbot bench --only teleop --busy-core --json  # issue 14: one core kept busy

``TELEOP_TRACE=DIR`` adds per-hop time stamps inside the station and the daemon
(``bench/_hop_trace.py``; ``python bench/_hop_trace.py report DIR`` prints each hop's p50 / p99).

With ``--busy-core`` (figures ``teleop_busy_*``) another process spins on one core for the whole
measurement (``python -c "while True: pass"``), as on an operator's laptop running something
else. ``TELEOP_SAMPLES=N`` (1..5000) changes the number of samples (300; ``--quick`` 20): a
longer run turns at finer steps of rate, every command under the multiplexer's tablet limit
(a scaled-down command never reaches the mux exactly); 10 samples in a row not seen at the mux
stop the run with the reason. The tablet process's output goes to a file, not a pipe: its
final JSON line outgrows a pipe's 64 KiB from about 600 samples on, and a child blocked
writing to a pipe nobody reads never exits (the first 1,200-sample run "hung" that way).

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
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

ROBOT = "benchbot"
SAMPLES_VARIABLE = "TELEOP_SAMPLES"
DEFAULT_SAMPLES = 300
MAX_SAMPLES = 5000
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


def run(quick: bool = False, secure: bool = False, busy_core: bool = False) -> dict[str, Any]:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    with (
        common.quiet_logs(),
        tempfile.TemporaryDirectory(prefix="interbot-bench-") as tmp,
        busy_process(busy_core),
    ):
        out = _run(Path(tmp), QUICK_SAMPLES if quick else samples_from_env(), secure)
    prefix = "teleop_" + ("tls_" if secure else "") + ("busy_" if busy_core else "")
    return {k.replace("teleop_", prefix, 1): v for k, v in out.items()}


def samples_from_env() -> int:
    """``TELEOP_SAMPLES`` (1..5000), else 300; anything else is refused, naming the value."""
    text = os.environ.get(SAMPLES_VARIABLE, str(DEFAULT_SAMPLES))
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= MAX_SAMPLES:
        raise BenchTeleopError(f"{SAMPLES_VARIABLE}={text!r}: give a whole number of samples in 1..{MAX_SAMPLES}")  # fmt: skip
    return n


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
    if os.environ.get("TELEOP_TRACE"):  # diagnostic: per-hop stamps (bench/_hop_trace.py)
        cmd[1:3] = [str(Path(__file__).with_name("_hop_trace.py")), "daemon"]
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
    from PySide6.QtCore import QEventLoop, QSettings, Qt, QTimer
    from PySide6.QtWidgets import QApplication

    from base_station_app.main_window import MainWindow
    from base_station_app.station_controller import StationController
    from interbot_core import protocol as p
    from interbot_core.topological_map import load_topological_map
    from interbot_link import LinkSecurity, session_config

    app = QApplication.instance() or QApplication([sys.argv[0]])
    trace_dir = os.environ.get("TELEOP_TRACE")
    if trace_dir:
        _trace = importlib.util.spec_from_file_location("interbot_hop_trace", Path(__file__).with_name("_hop_trace.py"))  # fmt: skip
        hop_trace = importlib.util.module_from_spec(_trace)  # type: ignore[arg-type]
        _trace.loader.exec_module(hop_trace)  # type: ignore[union-attr]
        hop_trace.install_station(Path(trace_dir) / "station.json")
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

    station_session = None
    controller: StationController | None = None
    window = None
    client: subprocess.Popen[bytes] | None = None
    arrived: dict[tuple[float, float], float] = {}  # speed -> decoded in the tablet thread
    try:
        topo = load_topological_map(common.ISR_TOPO)
        wait_for_daemon(proc, log_path, STARTUP_TIMEOUT_S)
        tablet_auth, token = None, ""
        if keys is None:
            station_session = zenoh.open(session_config([], [endpoint]))
        else:
            station_sec = LinkSecurity.load(keys, "station", "station")
            station_session = zenoh.open(session_config([], [endpoint], security=station_sec))
            tablet_auth, token = _paired_tablet_auth(keys)
        controller = StationController(
            topo,
            station_session,
            topo_path=common.ISR_TOPO,
            tablet_port=0,
            robot_id=ROBOT,
            tablet_auth=tablet_auth,
        )

        def stamp(msg: object) -> None:  # the tablet thread, before the speed is forwarded
            if isinstance(msg, p.Speed):
                arrived.setdefault((msg.linear, msg.angular), time.monotonic())

        # The stamp runs first, in the tablet thread (a direct connection), then the forwarding.
        tablet = controller.tablet
        tablet.speed_received.disconnect(controller.tablet_teleop.on_speed)
        tablet.speed_received.connect(stamp, Qt.ConnectionType.DirectConnection)
        tablet.speed_received.connect(controller.tablet_teleop.on_speed)
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
                and state.mux is not None
            )

        wait_until(robot_ready, STARTUP_TIMEOUT_S, "the simulated robot (pose, map, scan, mux)")
        startup = time.perf_counter() - t_launch
        window.map_view.fit_map()
        config = {
            "port": controller.tablet.port,
            "endpoint": endpoint,
            "robot": ROBOT,
            "samples": n_samples,
            "seed": SEED,
            "timeout_s": SAMPLE_TIMEOUT_S,
            "keys": str(keys) if keys is not None else "",
            "fingerprint": tablet_auth.fingerprint if tablet_auth is not None else "",
            "token": token,
        }
        helper = Path(__file__).with_name("_teleop_tablet.py")
        client_out, client_err = tmp / "tablet.out", tmp / "tablet.err"
        with client_out.open("w") as out_file, client_err.open("w") as err_file:
            client = subprocess.Popen(  # to files: a pipe read only at the end would fill up
                [sys.executable, str(helper), json.dumps(config)],
                cwd=common.REPO,
                stdout=out_file,
                stderr=err_file,
            )
        wait_until(lambda: controller.tablet.is_connected, 20.0, "the tablet connection")
        controller.clock_periods.clear()
        scan_count[0] = 0
        t0 = time.perf_counter()
        budget = 30.0 + n_samples * (0.1 + SAMPLE_TIMEOUT_S)
        wait_until(lambda: client.poll() is not None, budget, "the tablet's samples")
        wall = time.perf_counter() - t0
        out_text = client_out.read_text(encoding="utf-8")
        err_text = client_err.read_text(encoding="utf-8")
        if client.returncode != 0:
            raise BenchTeleopError(f"bench_teleop: the tablet process failed: {err_text[-2000:]}")
        result = json.loads(out_text.strip().splitlines()[-1])
        if result.get("aborted"):
            raise BenchTeleopError(f"bench_teleop: the tablet stopped sampling: {result['aborted']}")  # fmt: skip
        clock = controller.clock_periods.summary(threshold=0.11)
    finally:
        if client is not None and client.poll() is None:
            client.kill()
            client.wait()
        if window is not None:
            window.close()  # writes its settings to tmp and shuts the controller down
        elif controller is not None:
            controller.shutdown()
        if station_session is not None:
            station_session.close()
        app.processEvents()

    if trace_dir:
        samples = {"result": result, "arrived": [[k[0], k[1], t] for k, t in arrived.items()]}
        (Path(trace_dir) / "samples.json").write_text(json.dumps(samples), encoding="utf-8")
    written = {(lin, ang): t for lin, ang, t in result["written"]}
    total, tcp_in, to_mux = [], [], []
    for lin, ang, t_mux in result["observed"]:
        t_write = written[(lin, ang)]
        total.append(t_mux - t_write)
        t_arrive = arrived.get((lin, ang))
        if t_arrive is None:
            continue
        tcp_in.append(t_arrive - t_write)
        to_mux.append(t_mux - t_arrive)
    missed = len(result["written"]) - len(result["observed"])
    out: dict[str, Any] = {}
    out.update(common.summary_ms(total, "teleop_latency", median_name="p50"))
    out.update(common.summary_ms(tcp_in, "teleop_tcp_to_station", median_name="p50"))
    out.update(common.summary_ms(to_mux, "teleop_station_to_mux", median_name="p50"))
    out["teleop_samples"] = float(len(total))
    out["teleop_missed"] = float(missed)
    reasons = result["miss_reasons"]
    if reasons:  # what the robot's mux said instead (e.g. the collision monitor)
        out["teleop_miss_reasons"] = dict(sorted(reasons.items(), key=lambda kv: -kv[1])[:5])
    out["clock_period_ms_p50"] = clock.p50 * 1e3
    out["clock_period_ms_p99"] = clock.p99 * 1e3
    out["clock_period_ms_max"] = clock.maximum * 1e3
    out["clock_periods"] = float(clock.count)
    out["station_scan_view_hz"] = scan_count[0] / wall
    out["teleop_startup_s"] = startup  # daemon launch to robot state in the station's view
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
