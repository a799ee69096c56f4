"""`interbot` command line: ``demo``, ``scenario``, ``bench``, ``calibrate``, ``router``, ``keys``.

This package only composes the others (the core never imports the daemon or the apps); each
subcommand validates its arguments and fails with a one-line message, never a traceback.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from interbot_cli import bench, calibrate, demo, keys, replay, router

logger = logging.getLogger(__name__)

EXIT_USAGE = 2
EXIT_NOT_BUILT = 3


class NotBuiltError(RuntimeError):
    """A part of the system this command needs does not exist yet."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="interbot", description="Interbot human-robot interaction stack."
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p_demo = sub.add_parser(
        "demo", help="start the simulated robot, the Base Station and the Tablet"
    )
    demo.add_arguments(p_demo)

    p_scn = sub.add_parser("scenario", help="run a thesis test scenario headless on simulated time")
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
        "--cold-start", action="store_true", help="kidnap: start with the pose unset instead"
    )
    p_scn.add_argument(
        "--idle-standing",
        action="store_true",
        help="kidnap: a robot kidnapped standing at a tour stop is sent no next leg (idle)",
    )
    p_scn.add_argument(
        "--record", metavar="FILE.mcap", help="record the run (with the simulator's truth) to MCAP"
    )

    p_replay = sub.add_parser(
        "replay", help="play an MCAP recording back as a robot the station can watch"
    )
    replay.add_arguments(p_replay)

    p_bench = sub.add_parser("bench", help="run the benchmarks and print medians and p99")
    bench.add_arguments(p_bench)

    p_cal = sub.add_parser(
        "calibrate", help="calibrate the robot (odometry: thesis Test Scenario 1)"
    )
    calibrate.add_arguments(p_cal)

    p_router = sub.add_parser("router", help="run the building's zenoh router")
    router.add_arguments(p_router)

    p_keys = sub.add_parser("keys", help="certificates for the secure links (docs/security.md)")
    keys.add_arguments(p_keys)
    return parser


def run_scenario(args: argparse.Namespace) -> int:
    from robot_daemon import scenarios

    return scenarios.main(args)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        if args.command == "demo":
            return demo.run(args)
        if args.command == "scenario":
            return run_scenario(args)
        if args.command == "bench":
            return bench.run(args)
        if args.command == "replay":
            return replay.run(args)
        if args.command == "calibrate":
            return calibrate.run(args)
        if args.command == "router":
            return router.run(args)
        if args.command == "keys":
            return keys.run(args)
    except NotBuiltError as exc:
        print(f"interbot {args.command}: {exc}", file=sys.stderr)
        return EXIT_NOT_BUILT
    except bench.BenchError as exc:
        print(f"interbot bench: {exc}", file=sys.stderr)
        return EXIT_USAGE
    parser.error(f"unknown command {args.command!r}")
    return EXIT_USAGE  # pragma: no cover  (parser.error exits)


if __name__ == "__main__":
    sys.exit(main())
