"""`interbot replay FILE.mcap`: play a recording back as a robot the Base Station can watch.

    interbot replay recordings/interbot1_20261123-115250_0001.mcap --listen tcp/127.0.0.1:7447
    interbot-base-station --connect tcp/127.0.0.1:7447

The replay is robot ``<robot_id>`` (from the recording; ``--robot-id`` overrides it): it publishes
the usual topics, and the station's map view shows a replay bar (play, pause, speed ×0.5–×20,
time slider). Ctrl-C or SIGTERM stops it.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from types import FrameType


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, help="an MCAP recording (interbot-daemon --record)")
    parser.add_argument(
        "--listen", action="append", default=[], help="zenoh endpoint tcp/HOST:PORT"
    )
    parser.add_argument(
        "--connect", action="append", default=[], help="zenoh endpoint to connect to"
    )
    parser.add_argument("--robot-id", help="robot id (default: the recording's)")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed, 0.5 to 20")
    parser.add_argument("--paused", action="store_true", help="start paused")


def run(args: argparse.Namespace) -> int:
    from interbot_core.replay_control import SPEED_MAX, SPEED_MIN
    from interbot_core.topics import TopicError, validate_robot_id
    from interbot_link import LinkError, validate_endpoint
    from robot_daemon.recording.replay import RecordingSource, ReplayFileError, serve_replay

    try:
        if not SPEED_MIN <= args.speed <= SPEED_MAX:
            raise ValueError(f"--speed {args.speed} is outside [{SPEED_MIN}, {SPEED_MAX}]")
        for endpoint in args.listen:
            validate_endpoint(endpoint, listen=True)
        for endpoint in args.connect:
            validate_endpoint(endpoint, listen=False)
        if args.robot_id is not None:
            validate_robot_id(args.robot_id)
        RecordingSource(args.file).close()  # refuse a bad file before taking over the signals
        listen = args.listen or ([] if args.connect else ["tcp/127.0.0.1:7447"])
        stop = threading.Event()

        def on_signal(signum: int, _frame: FrameType | None) -> None:
            stop.set()

        signal.signal(signal.SIGTERM, on_signal)
        signal.signal(signal.SIGINT, on_signal)
        serve_replay(
            args.file,
            listen,
            list(args.connect),
            stop,
            robot_id=args.robot_id,
            speed=args.speed,
            paused=args.paused,
            ready=lambda robot: print(f"replaying {args.file} as robot {robot}", flush=True),
        )
    except (ReplayFileError, TopicError, LinkError, ValueError) as exc:
        print(f"interbot replay: {exc}", file=sys.stderr)
        return 2
    return 0
