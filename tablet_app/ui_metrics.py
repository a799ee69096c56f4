"""Sizes that keep the Tablet usable by touch on any screen (ISO 9241-9 / WCAG-style targets).

A touch target should be at least about 9 mm wide: ``9 / 25.4 * dpi`` pixels (57 px at 160 dpi).
On large screens targets and fonts also grow with the window so the layout scales with the
resolution and keeps its proportions. Pure functions; no Qt.
"""

from __future__ import annotations

MIN_TOUCH_MM = 9.0
MIN_TOUCH_PX = 44  # never smaller, whatever the reported dpi


def touch_target_px(logical_dpi: float, window_width: int, window_height: int) -> int:
    """Smallest side of a touch target [px]: 9 mm at ``logical_dpi``, or 1/16 of the window's
    shorter side if that is larger."""
    physical = MIN_TOUCH_MM / 25.4 * max(1.0, logical_dpi)
    relative = min(window_width, window_height) / 16.0
    return max(MIN_TOUCH_PX, round(physical), round(relative))


def font_px(touch_px: int) -> int:
    """Body text size [px] for a given touch-target size."""
    return max(14, round(touch_px * 0.36))
