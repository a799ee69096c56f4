"""`interbot demo`: the simulated robot, the Base Station and the Tablet on this machine.

All links stay on 127.0.0.1 with ports the OS picks. On a machine with no display this says so
and how to proceed, instead of a Qt platform traceback; on an X11 display whose system lacks the
libraries Qt's xcb plugin needs, it installs them when it may (root or passwordless sudo) or
prints the one command to run (`system_libs`).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys

NO_DISPLAY_HELP = """\
interbot demo: no display found (neither DISPLAY nor WAYLAND_DISPLAY is set).
The demo opens two windows (Base Station and Tablet). To proceed, either
  * run it under a virtual X server:   xvfb-run -s '-screen 0 1920x1080x24' make demo
    (Debian: apt-get install xvfb), then take screenshots with `make screenshots`; or
  * run the robot stack headless:      .venv/bin/interbot scenario tour
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=int, default=1, help="simulation seed")
    parser.add_argument("--people", type=int, default=4, help="people walking the corridors")
    parser.add_argument(
        "--duration", type=float, default=0.0, help="stop after this many seconds (0: run on)"
    )
    parser.add_argument(
        "--insecure-demo",
        action="store_true",
        help="plaintext links as in the thesis (default: mutual TLS, paired tablet, keys "
        "made on first use in ~/.config/interbot/demo-keys)",
    )


def has_display() -> bool:
    if os.environ.get("QT_QPA_PLATFORM", "").startswith(("offscreen", "minimal", "vnc")):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def missing_parts() -> list[str]:
    parts = {
        "robot daemon (issue 4)": "robot_daemon.daemon",
        "Base Station (issue 5)": "base_station_app.main_window",
        "Tablet (issue 6)": "tablet_app.main_window",
    }
    return [name for name, module in parts.items() if importlib.util.find_spec(module) is None]


def run(args: argparse.Namespace) -> int:
    from interbot_cli.main import NotBuiltError

    if not has_display():
        print(NO_DISPLAY_HELP, file=sys.stderr, end="")
        return 2
    missing = missing_parts()
    if missing:
        raise NotBuiltError("the demo needs parts that are not built yet: " + ", ".join(missing))
    from interbot_cli import demo_launcher, system_libs

    if system_libs.uses_xcb():
        try:
            system_libs.ensure_xcb_libraries()
        except system_libs.SystemLibsError as exc:
            print(f"interbot demo: {exc}", file=sys.stderr)
            return 2

    return int(demo_launcher.launch(args))
