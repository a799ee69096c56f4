"""What the collision monitor's report says to the person driving (station and tablet).

The robot's monitor (robot_daemon/safety, issue 17) reports its most restrictive active zone and
the distance from the footprint to the nearest laser return. Both user interfaces word it the
same way; ``level`` picks the colour (info / warning / error). It is NOT a certified safety
function and the text never claims to be.
"""

from __future__ import annotations

from dataclasses import dataclass

ZONE_WORDS = {
    "none": "clear",
    "slowdown": "slowing down: obstacle near",
    "limit": "speed limited",
    "approach": "slowing: obstacle ahead",
    "stop": "STOPPED: obstacle too close",
    "no_data": "STOPPED: no laser data",
}
NEAR_M = 0.5  # [m] distances below this are shown


@dataclass(frozen=True)
class SafetyText:
    text: str
    level: str  # info | warning | error


def describe_safety(zone: str, distance: float, assisted: bool | None = None) -> SafetyText:
    """e.g. ``STOPPED: obstacle too close (4 cm)``; ``assisted`` appends the assistance state."""
    words = ZONE_WORDS.get(zone, zone)
    if 0.0 <= distance < NEAR_M and zone != "no_data":
        words += f" ({distance * 100:.0f} cm)"
    if assisted is not None:
        words += "; assisted driving on" if assisted else "; assisted driving off"
    level = {"none": "info", "stop": "error", "no_data": "error"}.get(zone, "warning")
    return SafetyText(words, level)
