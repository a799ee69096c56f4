"""Room labels on the station's map: "name (node)", with the number alone where it does not fit.

The rooms, their own nodes and their label points come from `interbot_core.rooms` (the model
the tablet's map uses too); this is only how the station words them.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass

from interbot_core.rooms import RoomMap

SNAP_RADIUS = 1.5  # [m] a click this close to a room's node (a door in the corridor) selects it


@dataclass(frozen=True)
class MapLabel:
    """A label on the station's map: ``text`` centred at (x, y) [m], map frame."""

    text: str
    x: float
    y: float
    node_id: int  # the node a click on this room selects (its own node)
    short: str = ""  # shown when the room is too small on screen for ``text`` (its number)
    width: float = math.inf  # [m] room width available to the label


def map_labels(rooms: RoomMap, wrap: int = 16) -> list[MapLabel]:
    """One label per room at its label point, naming its own node ("Bar (13)"); names longer
    than ``wrap`` characters are broken onto several lines."""
    labels = []
    for room in rooms.rooms:
        text = "\n".join(textwrap.wrap(f"{room.name} ({room.id})", wrap))
        width = room.width if room.explicit else math.inf
        labels.append(MapLabel(text, room.label[0], room.label[1], room.id, str(room.id), width))
    return labels
