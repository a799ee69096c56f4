"""Entry point of `interbot-tablet`: the Tablet human-robot interface (thesis §4.2.1, §5.2).

    interbot-tablet [--host H] [--port P] [--windowed] [--geometry X,Y,W,H] [--screen N]
                    [--lang en|pt] [--topo T.yaml]

Connects to the Base Station's tablet server (default 127.0.0.1:5555), reconnecting by itself,
and shows the main menu full screen as a kiosk: frameless and sized to the whole screen's
geometry, which also fills the screen when no window manager runs (where ``showFullScreen``
alone leaves a small window). ``--screen N`` picks the screen; ``--windowed`` gives a 1280x800
window (or ``--geometry``).

    interbot-tablet --pair 'interbot-pair://HOST:PORT?fp=...&code=123456'   # once
    interbot-tablet                                                         # then, paired

A paired tablet (issue 15) talks TLS to the station whose certificate it pinned and
authenticates with its token (kept in ``--credentials``); an unpaired one speaks the thesis's
plaintext protocol, which is allowed only to 127.0.0.1 unless ``--insecure-tablet``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from interbot_core.occupancy_grid import MapLoadError, OccupancyGrid, load_map
from interbot_core.rooms import RoomMap, RoomMapError, load_room_map
from interbot_core.screen_layout import LayoutError, parse_geometry
from interbot_core.tablet_pairing import PairingError, parse_pairing_uri
from interbot_core.topological_map import TopologicalMapError

if TYPE_CHECKING:
    from PySide6.QtWidgets import QWidget

    from tablet_app.tablet_connection import TabletConnection

logger = logging.getLogger(__name__)

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_TOPO = REPO_ROOT / "maps" / "isr_floor0_topo.yaml"
DEFAULT_CREDENTIALS = Path("~/.config/interbot/tablet.json")


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="interbot-tablet", description="Interbot Tablet: map, joystick and tasks."
    )
    parser.add_argument("--host", default="127.0.0.1", help="Base Station address")
    parser.add_argument("--port", type=int, default=5555, help="Base Station tablet port")
    parser.add_argument("--windowed", action="store_true", help="a window instead of full screen")
    parser.add_argument(
        "--geometry", metavar="X,Y,W,H", help="window position and size (with --windowed)"
    )
    parser.add_argument(
        "--screen", type=int, default=0, metavar="N", help="screen to fill (default: primary)"
    )
    parser.add_argument("--lang", choices=("en", "pt"), default="en", help="UI language")
    parser.add_argument(
        "--dpi",
        type=float,
        help="the screen's real dots per inch, for 9 mm touch targets (default: Qt's figure)",
    )
    parser.add_argument("--topo", type=Path, default=DEFAULT_TOPO, help="topological map YAML")
    parser.add_argument(
        "--pair", metavar="URI", help="pair with a station: the address its Tablet tab shows"
    )
    parser.add_argument(
        "--credentials",
        type=Path,
        default=DEFAULT_CREDENTIALS,
        help="where the pairing is kept (default ~/.config/interbot/tablet.json)",
    )
    parser.add_argument("--name", default="tablet", help="this tablet's name at the station")
    parser.add_argument(
        "--insecure-tablet",
        action="store_true",
        help="plaintext protocol to a station off this machine (thesis-era, trusted networks)",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    args = parser.parse_args(argv)
    if not 0 < args.port < 65536:
        parser.error(f"--port must be in 1..65535, got {args.port}")
    if args.dpi is not None and not 50.0 <= args.dpi <= 1000.0:
        parser.error(f"--dpi must be in 50..1000, got {args.dpi}")
    if args.screen < 0:
        parser.error(f"--screen must be >= 0, got {args.screen}")
    if args.geometry is not None:
        try:
            args.geometry = parse_geometry(args.geometry)
        except LayoutError as exc:
            parser.error(f"--geometry: {exc}")
    return args


def show_kiosk(window: QWidget, screen_index: int = 0) -> None:
    """Full screen on screen ``screen_index`` (the primary if there is no such screen).

    The geometry is set to the screen's before ``showFullScreen``: without a window manager Qt
    does not resize a window on its own, and the tablet would open at its size hint.
    """
    from PySide6.QtCore import Qt
    from PySide6.QtGui import QGuiApplication

    screens = QGuiApplication.screens()
    screen = screens[screen_index] if screen_index < len(screens) else screens[0]
    if screen_index >= len(screens):
        logger.warning("no screen %d (%d screens); using the primary", screen_index, len(screens))
    window.setWindowFlag(Qt.WindowType.FramelessWindowHint, True)
    if hasattr(window, "kiosk"):
        window.kiosk = True  # no way out but the operator's gesture (tablet_app.kiosk)
    window.setGeometry(screen.geometry())
    window.showFullScreen()


def load_plan(topo: Path) -> tuple[RoomMap, OccupancyGrid | None]:
    """The rooms, and the occupancy grid under them when it can be read (else None)."""
    plan = load_room_map(topo)
    grid = None
    if plan.topo.map_yaml_path is not None:
        try:
            grid = load_map(plan.topo.map_yaml_path)
        except MapLoadError as exc:
            logger.warning("floor image not shown: %s", exc)
    return plan, grid


def make_connection(args: argparse.Namespace) -> TabletConnection:
    """Paired TLS (``--pair`` or saved credentials), or plaintext to loopback / when insecure."""
    from tablet_app.pairing import PairedTlsConnection, TabletCredentials
    from tablet_app.tablet_connection import TabletConnection

    credentials = args.credentials.expanduser()
    if args.pair:
        target = parse_pairing_uri(args.pair)
        link = PairedTlsConnection(target.fingerprint, pairing_code=target.code, name=args.name)
        link.paired.connect(lambda creds: creds.save(credentials))
        logger.info("pairing with the station at %s:%d", target.host, target.port)
        return TabletConnection(target.host, target.port, link=link)
    creds = None
    if credentials.exists() and not args.insecure_tablet:
        creds = TabletCredentials.load(credentials)
        # Saved pairing applies unless --host/--port name another station.
        if (args.host, args.port) not in (("127.0.0.1", 5555), (creds.host, creds.port)):
            creds = None
    if creds is not None:
        link = PairedTlsConnection(creds.fingerprint, token=creds.token)
        logger.info(
            "paired as %s with %s:%d (%s)", creds.tablet_id, creds.host, creds.port, credentials
        )
        return TabletConnection(creds.host, creds.port, link=link)
    if not is_loopback(args.host) and not args.insecure_tablet:
        raise PairingError(
            f"this tablet is not paired: refusing plaintext to {args.host}. At the station's "
            "Tablet tab press 'Pair a tablet', then run interbot-tablet --pair 'URI' with the "
            "address it shows (or, on a trusted network only, --insecure-tablet)"
        )
    if args.insecure_tablet:
        logger.warning("INSECURE: plaintext tablet link to %s:%d", args.host, args.port)
    return TabletConnection(args.host, args.port)


def is_loopback(host: str) -> bool:
    import ipaddress

    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        plan, grid = load_plan(args.topo)
    except (TopologicalMapError, RoomMapError, OSError) as exc:
        logger.error("cannot load the topological map: %s (use --topo FILE)", exc)
        return 2

    from PySide6.QtWidgets import QApplication

    from tablet_app.main_window import TabletWindow
    from tablet_app.translations import LanguageSwitcher

    app = QApplication.instance() or QApplication([sys.argv[0]])
    languages = LanguageSwitcher()
    languages.set_language(args.lang)
    try:
        connection = make_connection(args)
    except PairingError as exc:
        logger.error("%s", exc)
        return 2
    window = TabletWindow(connection, plan, grid, languages, dpi=args.dpi)
    if args.windowed:
        if args.geometry is not None:
            g = args.geometry
            window.setGeometry(g.x, g.y, g.w, g.h)
        else:
            window.resize(1280, 800)
        window.show()
    else:
        show_kiosk(window, args.screen)
    connection.start()
    code = app.exec()
    connection.stop()
    return int(code)


if __name__ == "__main__":
    sys.exit(main())
