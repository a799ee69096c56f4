"""`interbot` command line: ``demo``, ``scenario``, ``bench``, ``calibrate``, ``router``, ``keys``.

This package only composes the others (the core never imports the daemon or the apps); each
subcommand validates its arguments and fails with a one-line message, never a traceback.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from typing import Any, Final

from interbot_cli import bench, calibrate, demo, keys, replay, router

logger = logging.getLogger(__name__)

EXIT_USAGE = 2
EXIT_NOT_BUILT = 3


class NotBuiltError(RuntimeError):
    """A part of the system this command needs does not exist yet."""


Runner = Callable[[argparse.Namespace], int]


def _of(module: Any) -> tuple[Callable[[argparse.ArgumentParser], None], Runner]:
    """A subcommand module's ``add_arguments`` and ``run``."""
    return module.add_arguments, module.run


def _scenario_arguments(p_scn: argparse.ArgumentParser) -> None:
    p_scn.add_argument("name", help="odometry | tour | mission | latency | kidnap")
    p_scn.add_argument("--map", dest="map_yaml", help="map_server YAML (default: ISR floor 0)")
    p_scn.add_argument("--topo", help="topological map YAML")
    p_scn.add_argument("--seed", type=int, default=1)
    p_scn.add_argument(
        "--ideal-world",
        action="store_true",
        help="simulate in the map itself, initial pose exact (best case; default: a simulated "
        "building that differs from the map)",
    )
    p_scn.add_argument("--json", action="store_true", help="last line: one JSON object")
    p_scn.add_argument(
        "--cold-start",
        action="store_true",
        help="kidnap: power on with the pose unset instead; the operator presses the station's "
        '"Relocalise" at once (a command: the robot may turn to look around)',
    )
    p_scn.add_argument(
        "--idle-at-power-on",
        action="store_true",
        help='kidnap --cold-start: nobody presses "Relocalise"; the idle robot searches '
        "standing still (no motion nobody commanded)",
    )
    p_scn.add_argument(
        "--idle-after-kidnap",
        action="store_true",
        help="kidnap: a robot kidnapped standing at a tour stop stays idle (default: the "
        "station's supervisor sends it the next leg after a dwell, which it plans from the "
        "pose it finds)",
    )
    p_scn.add_argument(
        "--record", metavar="FILE.mcap", help="record the run (with the simulator's truth) to MCAP"
    )


def run_scenario(args: argparse.Namespace) -> int:
    from robot_daemon import scenarios

    return scenarios.main(args)


_SCENARIO: Final = (_scenario_arguments, run_scenario)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="interbot", description="Interbot human-robot interaction stack."
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    commands: tuple[tuple[str, str, Callable[[argparse.ArgumentParser], None], Runner], ...] = (
        ("demo", "start the simulated robot, the Base Station and the Tablet", *_of(demo)),
        ("scenario", "run a thesis test scenario headless on simulated time", *_SCENARIO),
        ("replay", "play an MCAP recording back as a robot the station can watch", *_of(replay)),
        ("bench", "run the benchmarks and print medians and p99", *_of(bench)),
        ("calibrate", "calibrate the robot (odometry: thesis Test Scenario 1)", *_of(calibrate)),
        ("router", "run the building's zenoh router", *_of(router)),
        ("keys", "certificates for the secure links (docs/security.md)", *_of(keys)),
    )
    for name, text, add_arguments, run in commands:
        command = sub.add_parser(name, help=text)
        add_arguments(command)
        command.set_defaults(run=run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        return int(args.run(args))
    except NotBuiltError as exc:
        print(f"interbot {args.command}: {exc}", file=sys.stderr)
        return EXIT_NOT_BUILT
    except bench.BenchError as exc:
        print(f"interbot bench: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
