"""Entry point of ``interbot-base-station`` (thesis §5.3 start-up sequence).

Start-up, as in the thesis: create the TCP server for the tablet and listen, connect the UI,
start the timers, open the robot link (here a zenoh session with multicast scouting off and
explicit connect endpoints) and load the topological map with every route precomputed. The
zenoh session is closed from ``QApplication.aboutToQuit`` (and the window's ``closeEvent``), so
the process never hangs at exit (zenoh-python#434).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import zenoh

from base_station_app import station_file, station_security
from base_station_app.station_file import StationSettingsStore
from interbot_core.screen_layout import LayoutError, parse_geometry
from interbot_core.topological_map import TopologicalMapError, load_topological_map
from interbot_link import LinkError, LinkSecurity, session_config

if TYPE_CHECKING:
    from PySide6.QtCore import QSettings

logger = logging.getLogger(__name__)

# Beside the packages in a checkout or an editable install, whatever the working directory.
DEFAULT_TOPO = Path(__file__).resolve().parent.parent / "maps" / "isr_floor0_topo.yaml"


class StationSession:
    """Owns the zenoh session; `close` is idempotent (called from aboutToQuit and closeEvent)."""

    def __init__(
        self,
        connect: Sequence[str],
        mode: str = "peer",
        lease_ms: int = 2500,
        *,
        security: LinkSecurity | None = None,
        insecure: bool = False,
    ) -> None:
        config = session_config(
            [], list(connect), mode, lease_ms=lease_ms, security=security, insecure=insecure
        )
        self.session: zenoh.Session | None = zenoh.open(config)
        logger.info("zenoh session open, connecting to %s", list(connect))

    def close(self) -> None:
        if self.session is not None:
            session, self.session = self.session, None
            session.close()
            logger.info("zenoh session closed")


def migrate_qsettings(store: StationSettingsStore, qsettings: QSettings | None = None) -> None:
    """Move the ``config/*`` and ``tablet/*`` QSettings of a station from before the station
    file into the file (`station_file.migrate_legacy`), log what moved, then remove them. A file
    that cannot be read or written raises `StationFileError` and the old values stay."""
    from PySide6.QtCore import QSettings

    qsettings = qsettings if qsettings is not None else QSettings("Interbot", "BaseStation")
    keys = [k for k in qsettings.allKeys() if k.startswith(station_file.LEGACY_PREFIXES)]
    if not keys:
        return
    old = {legacy_key: qsettings.value(legacy_key) for legacy_key in keys}
    for note in station_file.migrate_legacy(store, old):
        logger.warning("old station setting %s", note)
    for legacy_key in keys:
        qsettings.remove(legacy_key)
    qsettings.sync()


def _fail(text: str) -> int:
    """Say why the station cannot start; the exit status of a usage or set-up error."""
    sys.stderr.write(f"interbot-base-station: {text}\n")
    return 2


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="interbot-base-station",
        description="Interbot Base Station: monitor and control robots, serve the tablet.",
    )
    parser.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint of a robot or router (repeatable; default tcp/127.0.0.1:7447)",
    )
    parser.add_argument(
        "--mode",
        choices=("peer", "client"),
        default="peer",
        help="zenoh mode: peer (connect to robots) or client (of a building's router)",
    )
    parser.add_argument(
        "--tablet-host", default="127.0.0.1", help="address to listen on for the tablet"
    )
    parser.add_argument("--tablet-port", type=int, default=5555, help="TCP port for the tablet")
    parser.add_argument(
        "--robot",
        metavar="ID",
        help="robot to command (default: the one commanded last; with several robots and no "
        "choice the station asks)",
    )
    parser.add_argument("--topo", type=Path, default=DEFAULT_TOPO, help="topological map YAML")
    parser.add_argument(
        "--security",
        type=Path,
        metavar="DIR",
        help="key directory (interbot keys init DIR): mutual TLS to robots on tls/ endpoints "
        "and a paired TLS tablet",
    )
    parser.add_argument("--identity", help="this station's certificate name (default station)")
    parser.add_argument(
        "--insecure",
        action="store_true",
        help="allow plaintext robot endpoints off the loopback interface (trusted networks)",
    )
    parser.add_argument(
        "--insecure-tablet",
        action="store_true",
        help="serve the thesis's plaintext tablet protocol (no TLS, no pairing)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        help="station file (security, config, tablet permissions; docs/station_config.md); "
        "default $XDG_CONFIG_HOME/interbot/station.yaml",
    )
    parser.add_argument(
        "--geometry", metavar="X,Y,W,H", help="window position and size (default 1600x1000)"
    )
    parser.add_argument("--log-level", default="INFO")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, str(args.log_level).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        topo = load_topological_map(args.topo)
    except (TopologicalMapError, OSError) as exc:
        return _fail(str(exc))
    if not 0 < args.tablet_port < 65536:
        return _fail("--tablet-port must be 1..65535")
    connect = args.connect or ["tcp/127.0.0.1:7447"]
    try:
        geometry = None if args.geometry is None else parse_geometry(args.geometry)
    except LayoutError as exc:
        return _fail(f"--geometry: {exc}")
    settings = StationSettingsStore(args.config or station_file.default_path())
    try:
        migrate_qsettings(settings)
        saved = settings.load()
    except station_file.StationFileError as exc:
        return _fail(str(exc))
    try:
        security = station_security.resolve(
            keys=args.security,
            identity=args.identity,
            insecure=args.insecure,
            insecure_tablet=args.insecure_tablet,
            connect=connect,
            tablet_host=args.tablet_host,
            file_settings=station_security.settings_of(saved.security, settings.path),
        )
        holder = StationSession(
            connect, args.mode, security=security.link, insecure=security.insecure
        )
    except station_security.StationSecurityError as exc:
        return _fail(str(exc))
    except (LinkError, zenoh.ZError) as exc:
        hint = (
            " (is the building's router running? start it with `interbot router`)"
            if args.mode == "client"
            else ""
        )
        return _fail(f"cannot open the zenoh session: {exc}{hint}")

    from PySide6.QtCore import Qt, QTimer
    from PySide6.QtWidgets import QApplication

    from base_station_app.main_window import MainWindow
    from base_station_app.station_controller import StationController

    app = QApplication.instance() or QApplication(sys.argv[:1])
    tablet_auth = None
    if security.tablet_tls and security.link is not None:
        from base_station_app.tablet_auth import (
            TabletAuthServer,
            TabletTlsError,
            advertised_address,
        )

        try:
            identity = security.link.identity
            tablet_auth = TabletAuthServer.from_files(
                identity.cert, identity.key, security.registry_path(), time.time
            )
        except (TabletTlsError, ValueError) as exc:
            holder.close()
            return _fail(f"tablet link: {exc}")
        tablet_auth.advertised_host = advertised_address(args.tablet_host)
    controller = StationController(
        topo,
        holder.session,
        topo_path=args.topo,
        tablet_host=args.tablet_host,
        tablet_port=args.tablet_port,
        robot_id=args.robot,
        tablet_auth=tablet_auth,
        settings=settings,
    )
    if tablet_auth is not None:  # the operator sees who was refused or let in (issue 15)
        # Bound slots, not lambdas: the server lives in the tablet thread, the log in this one.
        tablet_auth.auth_refused.connect(controller.tablet_link.log_refused)
        tablet_auth.tablet_authorised.connect(controller.tablet_link.log_authorised)
    window = MainWindow(controller)
    window.setWindowTitle(window.windowTitle() + security.title_suffix())
    window.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose, False)
    app.aboutToQuit.connect(window.shutdown)
    app.aboutToQuit.connect(holder.close)

    # The frame timer runs Python every 25 ms, so these handlers are not starved by Qt. A Python
    # handler runs between two bytecodes of whatever the main thread is doing, possibly inside
    # a lock (the robot switch holds the tablet teleop's): quitting there ran the shutdown inline,
    # which waits for the tablet thread, which waited for that lock (a deadlock seen in CI). So
    # the handler only queues the quit; it runs from the event loop, with no lock held.
    def on_signal(*_: object) -> None:
        QTimer.singleShot(0, app.quit)

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        if not controller.start():
            return 1
        if geometry is None:
            window.resize(1600, 1000)
        else:
            window.setGeometry(geometry.x, geometry.y, geometry.w, geometry.h)
        window.show()
        window.map_view.fit_map()
        return int(app.exec())
    finally:
        app.aboutToQuit.disconnect(window.shutdown)
        app.aboutToQuit.disconnect(holder.close)
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        window.close()
        holder.close()


if __name__ == "__main__":
    sys.exit(main())
