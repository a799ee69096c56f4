"""`interbot router`: the building's zenoh router (`interbot_link.router`), until Ctrl-C/SIGTERM.

    interbot router [--listen tcp/HOST:PORT ...] [--lease-ms MS]

Robots (``interbot-daemon --mode client --connect tcp/ROUTER:7447``) and Base Stations
(``interbot-base-station --mode client --connect tcp/ROUTER:7447``) then find each other through
it. Listens on 127.0.0.1:7447 unless told otherwise.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from types import FrameType


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help="endpoint to listen on (repeatable; default tcp/127.0.0.1:7447)",
    )
    parser.add_argument("--lease-ms", type=int, default=2500, help="link lease [ms]")


def run(args: argparse.Namespace) -> int:
    from interbot_link import LinkError
    from interbot_link.router import run_router

    stop = threading.Event()

    def on_signal(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        run_router(args.listen or ["tcp/127.0.0.1:7447"], stop, args.lease_ms)
    except (LinkError, ValueError) as exc:
        print(f"interbot router: {exc}", file=sys.stderr)
        return 2
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 0
