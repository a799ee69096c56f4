"""`interbot-daemon`: the robot daemon (simulated robot by default).

    interbot-daemon --sim [--map M.yaml --topo T.yaml] [--seed N] --robot-id ID \\
                    --listen tcp/127.0.0.1:PORT [--connect tcp/HOST:PORT] [--config robot.yaml]
                    [--security KEYS_DIR (then tls/ endpoints) | --insecure]

Bad configuration is refused with one clear line and exit status 2; SIGTERM and SIGINT stop
the daemon cleanly (motors to zero, zenoh session closed).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

import msgspec

from interbot_core.occupancy_grid import MapLoadError
from interbot_core.topological_map import TopologicalMapError
from interbot_core.velocity_mux import MuxError
from interbot_link import LinkConfigError, LinkError
from robot_daemon.config import (
    ConfigError,
    DaemonConfig,
    SecuritySettings,
    ZenohSettings,
    load_config,
)

logger = logging.getLogger("robot_daemon")

EXIT_CONFIG = 2


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="interbot-daemon", description=__doc__.split("\n")[0])
    p.add_argument("--config", type=Path, help="robot.yaml (backends, rates, zenoh endpoints)")
    p.add_argument("--sim", action="store_true", help="simulated robot (the default backend)")
    p.add_argument("--map", dest="map_yaml", type=Path, help="map_server YAML")
    p.add_argument("--topo", dest="topo_yaml", type=Path, help="topological map YAML")
    p.add_argument("--seed", type=int, help="simulation seed")
    p.add_argument("--people", type=int, help="simulated people walking the corridors")
    p.add_argument("--speed", type=float, help="simulated time per wall second (default 1)")
    p.add_argument("--robot-id", help="robot id in interbot/<robot_id>/<topic>")
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        help="zenoh endpoint tcp/HOST:PORT (tls/HOST:PORT with --security)",
    )
    p.add_argument("--connect", action="append", default=[], help="zenoh endpoint to connect to")
    p.add_argument(
        "--mode",
        choices=("peer", "client"),
        help="zenoh mode: peer (listen; stations connect) or client (of a building's router)",
    )
    p.add_argument(
        "--security",
        type=Path,
        metavar="DIR",
        help="key directory (interbot keys init DIR): mutual TLS and access control on tls/ "
        "endpoints; the robot's certificate is the one named after its robot id",
    )
    p.add_argument(
        "--insecure",
        action="store_true",
        help="allow plaintext endpoints off the loopback interface (trusted networks only)",
    )
    p.add_argument(
        "--auto-localise",
        action="store_true",
        help="simulation: set the initial pose at the start node (otherwise the station or "
        "the tablet's 'Help me!' sets it, as in the thesis)",
    )
    p.add_argument("--start-node", type=int, help="simulation: start at this topological node")
    p.add_argument(
        "--record", type=Path, metavar="DIR", help="record the run to rotating MCAP files in DIR"
    )
    p.add_argument(
        "--foxglove",
        metavar="[HOST:]PORT",
        help="serve the run live to Foxglove (WebSocket; loopback only)",
    )
    p.add_argument(
        "--no-relocalise",
        action="store_true",
        help="do not search the map for the robot's pose by itself (a person gives it: Help me!)",
    )
    p.add_argument("-v", "--verbose", action="store_true")
    return p


def resolve_config(args: argparse.Namespace) -> DaemonConfig:
    """robot.yaml (or the defaults) with the command line's overrides; raises ConfigError."""
    config = load_config(args.config) if args.config else DaemonConfig(source="command line")
    if args.sim and config.backend != "sim":
        config = config.with_overrides(backend="sim")
    sim_changes = {"seed": args.seed, "people": args.people, "realtime_factor": args.speed}
    sim = msgspec.structs.replace(
        config.sim, **{k: v for k, v in sim_changes.items() if v is not None}
    )
    zenoh = config.zenoh
    if args.listen or args.connect or args.mode:
        # ZenohSettings checks the endpoints (pattern, port range) as it is built.
        mode = args.mode or zenoh.mode
        listen = tuple(args.listen) if args.listen or args.connect else zenoh.listen
        connect = tuple(args.connect) if args.listen or args.connect else zenoh.connect
        zenoh = ZenohSettings(listen, connect, zenoh.lease_ms, mode)
    security = config.security
    if args.security or args.insecure:
        security = SecuritySettings(
            str(args.security.resolve()) if args.security else security.keys,
            args.insecure or security.insecure,
        )
    return config.with_overrides(
        security=security,
        robot_id=args.robot_id,
        map=str(args.map_yaml.resolve()) if args.map_yaml else None,
        topo=str(args.topo_yaml.resolve()) if args.topo_yaml else None,
        sim=sim,
        zenoh=zenoh,
    )


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    from robot_daemon.daemon import DaemonOptions, serve

    stop = threading.Event()

    def on_signal(signum: int, _frame: FrameType | None) -> None:
        logger.info("signal %s: stopping", signal.Signals(signum).name)
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    try:
        config = resolve_config(args)
        logger.info("configuration: %s", config.summary())
        options = DaemonOptions(
            args.auto_localise,
            args.start_node,
            relocalise=not args.no_relocalise,
            record_dir=args.record,
            foxglove=args.foxglove,
        )
        serve(config, options, stop)
    except (ConfigError, LinkConfigError, MapLoadError, TopologicalMapError, MuxError) as exc:
        print(f"interbot-daemon: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    except LinkError as exc:
        print(f"interbot-daemon: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
