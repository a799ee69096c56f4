"""Start the simulated robot, the Base Station and the Tablet as three processes on 127.0.0.1.

Ports come from the OS; the robot daemon listens for zenoh on one, the station connects to it
and serves the tablet on another. The windows are placed by `demo_layout` (side by side on one
screen; the tablet full-screen on a second screen when there is one). The launcher watches the
three: when one exits (or on Ctrl-C / SIGTERM, or after ``--duration`` seconds) it stops the
others with SIGTERM and waits. By default the demo runs secure (issue 15): zenoh over mutual TLS
with access control and a paired TLS tablet, with keys made on first use
(`interbot_cli.demo_security`); ``--insecure-demo`` runs the plaintext links of the thesis.
"""

from __future__ import annotations

import argparse
import logging
import signal
import socket
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

from interbot_cli import demo_security
from interbot_core.screen_layout import DemoLayout, LayoutError, layout, parse_screens

logger = logging.getLogger(__name__)

ROBOT_ID = "interbot1"
STOP_TIMEOUT = 10.0  # [s] before a process that ignores SIGTERM is killed


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@dataclass(frozen=True)
class DemoPlan:
    """The three command lines of a demo run."""

    daemon: list[str]
    station: list[str]
    tablet: list[str]


def screen_layout() -> DemoLayout | None:
    """Ask Qt (in a child process) for the screens and lay the windows out; None if it cannot."""
    try:
        result = subprocess.run(
            [sys.executable, "-m", "interbot_cli.screens"],
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
    except subprocess.TimeoutExpired:
        logger.warning("could not read the screen geometry (timed out); windows left to Qt")
        return None
    if result.returncode != 0:
        logger.warning("could not read the screen geometry: %s", result.stderr.strip()[-300:])
        return None
    try:
        return layout(parse_screens(result.stdout))
    except LayoutError as exc:
        logger.warning("could not lay the windows out: %s", exc)
        return None


def window_args(where: DemoLayout | None) -> tuple[list[str], list[str]]:
    """The station's and the tablet's placement arguments."""
    if where is None:
        return [], ["--windowed"]
    station = ["--geometry", where.station.arg()]
    if where.tablet_screen is not None:
        return station, ["--screen", str(where.tablet_screen)]
    return station, ["--windowed", "--geometry", where.tablet.arg()]


def plan(
    seed: int,
    people: int,
    zenoh_port: int,
    tablet_port: int,
    where: DemoLayout | None = None,
    *,
    keys: Path | None = None,
    tablet_credentials: Path | None = None,
) -> DemoPlan:
    python = sys.executable
    endpoint = f"{'tls' if keys is not None else 'tcp'}/127.0.0.1:{zenoh_port}"
    secure = ["--security", str(keys)] if keys is not None else []
    creds = ["--credentials", str(tablet_credentials)] if tablet_credentials is not None else []
    station_place, tablet_place = window_args(where)
    demo = DemoPlan(
        daemon=[
            python, "-m", "robot_daemon.main", "--sim", "--robot-id", ROBOT_ID,
            "--listen", endpoint, "--seed", str(seed), "--people", str(people),
            "--auto-localise",
        ],
        station=[
            python, "-m", "base_station_app.main", "--connect", endpoint,
            "--tablet-host", "127.0.0.1", "--tablet-port", str(tablet_port), "--robot", ROBOT_ID,
            *station_place,
        ],
        tablet=[
            python, "-m", "tablet_app.main", "--host", "127.0.0.1", "--port", str(tablet_port),
            *tablet_place,
        ],
    )  # fmt: skip
    demo.daemon.extend(secure)
    demo.station.extend(secure)
    demo.tablet.extend(creds)
    return demo


def stop_all(processes: dict[str, subprocess.Popen[bytes]]) -> int:
    """SIGTERM every running process, wait, kill stragglers; 0 if all exited cleanly."""
    for proc in processes.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
    worst = 0
    for name, proc in processes.items():
        try:
            code = proc.wait(STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            logger.error("%s ignored SIGTERM; killing it", name)
            proc.kill()
            code = proc.wait()
        if code not in (0, -signal.SIGTERM):
            logger.error("%s exited with status %s", name, code)
            worst = 1
    return worst


def launch(args: argparse.Namespace) -> int:
    """Run the demo until a program exits, Ctrl-C, SIGTERM or ``args.duration`` seconds."""
    zenoh_port, tablet_port = free_port(), free_port()
    where = screen_layout()
    if getattr(args, "insecure_demo", False):
        demo = plan(args.seed, args.people, zenoh_port, tablet_port, where)
    else:
        store = demo_security.ensure_keys(demo_security.demo_keys_dir(), ROBOT_ID)
        creds = demo_security.pair_demo_tablet(store, tablet_port)
        demo = plan(
            args.seed,
            args.people,
            zenoh_port,
            tablet_port,
            where,
            keys=store.dir,
            tablet_credentials=creds,
        )
    stop = threading.Event()

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    processes: dict[str, subprocess.Popen[bytes]] = {}
    try:
        for name, cmd in (
            ("daemon", demo.daemon),
            ("station", demo.station),
            ("tablet", demo.tablet),
        ):
            logger.info("starting %s: %s", name, " ".join(cmd))
            processes[name] = subprocess.Popen(cmd)
        print(
            "interbot demo: simulated robot, Base Station and Tablet running "
            "(Ctrl-C stops all three)",
            flush=True,
        )
        waited = 0.0
        while not stop.is_set():
            exited = [name for name, p in processes.items() if p.poll() is not None]
            if exited:
                logger.info("%s exited; stopping the demo", ", ".join(exited))
                break
            if args.duration and waited >= args.duration:
                break
            stop.wait(0.2)
            waited += 0.2
        early = [n for n, p in processes.items() if p.poll() not in (None, 0)]
        status = stop_all(processes)
        return 1 if early else status
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
