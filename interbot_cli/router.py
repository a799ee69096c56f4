"""`interbot router`: the building's zenoh router (`interbot_link.router`), until Ctrl-C/SIGTERM.

    interbot router [--listen tcp/HOST:PORT ...] [--lease-ms MS]
    interbot router --security DIR [--identity router] --listen tls/HOST:PORT   (issue 15)

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
    parser.add_argument(
        "--security",
        metavar="DIR",
        help="key directory: mutual TLS and access control (a router certificate, "
        "interbot keys add-router NAME); endpoints tls/HOST:PORT",
    )
    parser.add_argument("--identity", default="router", help="the router's certificate name")
    parser.add_argument(
        "--insecure",
        action="store_true",
        help="allow plaintext endpoints off the loopback interface (trusted networks only)",
    )


def run(args: argparse.Namespace) -> int:
    from interbot_link import KeysError, LinkError, LinkSecurity
    from interbot_link.router import run_router
    from interbot_link.security import warn_insecure

    stop = threading.Event()

    def on_signal(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    default = "tls" if args.security else "tcp"
    listen = args.listen or [f"{default}/127.0.0.1:7447"]
    try:
        security = None
        if args.security:
            security = LinkSecurity.load(args.security, args.identity, "router")
        elif args.insecure:
            warn_insecure("interbot router", listen)
        run_router(listen, stop, args.lease_ms, security=security, insecure=args.insecure)
    except (KeysError, LinkError, ValueError) as exc:
        print(f"interbot router: {exc}", file=sys.stderr)
        return 2
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 0
