"""Where the demo puts its two windows: side by side on one screen, or one screen each.

With two or more screens the Base Station fills the first and the Tablet is full-screen on the
second, as on the robot. With one screen the Tablet keeps its 16:10 shape at the right, as large
as fits in 45 % of the width (at most 1280 x 800), and the Base Station takes the rest, so neither
hides the other. Screens are rectangles in Qt's virtual-desktop coordinates (``x, y, w, h``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass

TABLET_ASPECT = 16 / 10  # Nexus 10 and the 1280 x 800 / 2560 x 1600 screens we test
TABLET_MAX_W = 1280  # [px] the tablet window on a shared screen
TABLET_SHARE = 0.45  # of a shared screen's width


class LayoutError(ValueError):
    """A screen list that cannot be laid out (the message names the bad entry)."""


@dataclass(frozen=True)
class Rect:
    x: int
    y: int
    w: int
    h: int

    def __post_init__(self) -> None:
        if self.w <= 0 or self.h <= 0:
            raise LayoutError(f"screen size must be positive, got {self.w}x{self.h}")

    def arg(self) -> str:
        """As the ``--geometry X,Y,W,H`` argument of the station and the tablet."""
        return f"{self.x},{self.y},{self.w},{self.h}"


@dataclass(frozen=True)
class DemoLayout:
    station: Rect
    tablet: Rect
    tablet_screen: int | None  # full screen on this screen index, or None for a window


def layout(screens: Sequence[Rect]) -> DemoLayout:
    """The two windows' places for these screens (the first is the primary)."""
    if not screens:
        raise LayoutError("no screen to lay the demo out on")
    first = screens[0]
    if len(screens) >= 2:
        return DemoLayout(station=first, tablet=screens[1], tablet_screen=1)
    tablet_w = min(TABLET_MAX_W, int(first.w * TABLET_SHARE))
    tablet_h = min(int(tablet_w / TABLET_ASPECT), first.h)
    tablet_w = min(tablet_w, int(tablet_h * TABLET_ASPECT))
    tablet = Rect(first.x + first.w - tablet_w, first.y, tablet_w, tablet_h)
    station = Rect(first.x, first.y, first.w - tablet_w, first.h)
    return DemoLayout(station=station, tablet=tablet, tablet_screen=None)


def parse_geometry(text: str) -> Rect:
    """``"X,Y,W,H"`` (the command-line form) as a `Rect`."""
    parts = text.split(",")
    if len(parts) != 4:
        raise LayoutError(f"geometry must be X,Y,W,H, got {text!r}")
    try:
        x, y, w, h = (int(p) for p in parts)
    except ValueError:
        raise LayoutError(f"geometry must be four integers X,Y,W,H, got {text!r}") from None
    return Rect(x, y, w, h)


def parse_screens(text: str) -> list[Rect]:
    """The JSON that ``python -m interbot_cli.screens`` prints: a list of ``[x, y, w, h]``."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise LayoutError(f"screen list is not JSON: {exc}") from None
    if not isinstance(data, list) or not all(
        isinstance(s, list) and len(s) == 4 and all(type(v) is int for v in s) for s in data
    ):
        raise LayoutError(f"screen list must be [[x, y, w, h], ...], got {text.strip()!r}")
    return [Rect(*s) for s in data]
