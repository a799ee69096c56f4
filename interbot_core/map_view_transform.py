"""World (map frame) to widget pixel transform for map views (thesis §5.2.1.1, Algorithm 3).

Thesis Algorithm 3 (receivePos) places the robot on the Tablet's map widget with

    h_scale = height / 35,   w_scale = width / 70
    pos_X = (x + 35) * w_scale,   pos_Y = (y + 14.25) * h_scale,   arc = a

i.e. a 70 m x 35 m map whose lower-left corner is at (-35, -14.25) m, stretched to fill the
widget. `MapViewTransform` generalises it to any map rectangle and widget size, and differs in
two documented ways:

* **y is flipped.** Qt widget y grows *down*, while map y (REP-103) grows up (left of the
  robot's forward axis). Algorithm 3 did not flip, so its map appears mirrored top-to-bottom
  unless the background image was mirrored to match. We flip, so the map is drawn upright
  (north up) from an ordinary map image: ``py = offset_y + (top - y) * scale_y``. In thesis
  terms ``py_ours = height - pos_Y_thesis`` when the aspect is not kept.
* **aspect is kept by default** (``keep_aspect=True``): one isotropic scale
  ``min(width / map_width, height / map_height)`` and the map centred with letterbox offsets, so
  circles stay circles on any screen. ``keep_aspect=False`` stretches like the thesis.

Headings follow the same flip: a counter-clockwise world yaw becomes a clockwise-on-screen
widget angle, measured from the widget's +x axis towards its +y axis (down), which is what
``QPainter.rotate(math.degrees(angle))`` expects.
"""

from __future__ import annotations

import logging
import math
from functools import cached_property
from typing import Annotated, ClassVar

import msgspec
import numpy as np
from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)


class MapViewError(ValueError):
    """Invalid map rectangle or widget size for a map view transform."""


Metres = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "m"})]
Pixels = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "px"})]


class _Declared(schema.Declared, frozen=True):
    ERROR: ClassVar[type[Exception]] = MapViewError

    def __post_init__(self) -> None:
        for name in self.__struct_fields__:  # numpy scalars (map origins, sizes) as Python's
            value = getattr(self, name)
            if isinstance(value, np.floating | np.integer):
                msgspec.structs.force_setattr(self, name, value.item())
        super().__post_init__()


class MapViewTransform(_Declared, frozen=True, dict=True):
    """Map rectangle [m] (lower-left ``map_origin``, size) shown in a widget [px].

    ``scale_x``/``scale_y`` are px per metre; ``offset_x``/``offset_y`` [px] the letterbox margins.
    """

    ROOT: ClassVar[str] = "map view"
    map_origin_x: schema.Finite
    map_origin_y: schema.Finite
    map_width_m: Metres
    map_height_m: Metres
    widget_width_px: Pixels
    widget_height_px: Pixels
    keep_aspect: bool = True

    @cached_property
    def scale_x(self) -> float:
        sx = self.widget_width_px / self.map_width_m
        return min(sx, self.widget_height_px / self.map_height_m) if self.keep_aspect else sx

    @cached_property
    def scale_y(self) -> float:
        sy = self.widget_height_px / self.map_height_m
        return min(sy, self.widget_width_px / self.map_width_m) if self.keep_aspect else sy

    @cached_property
    def offset_x(self) -> float:
        return (self.widget_width_px - self.map_width_m * self.scale_x) / 2.0

    @cached_property
    def offset_y(self) -> float:
        return (self.widget_height_px - self.map_height_m * self.scale_y) / 2.0

    @cached_property
    def map_top_y(self) -> float:
        """World y of the map's top edge [m]."""
        return self.map_origin_y + self.map_height_m

    @property
    def scale(self) -> float:
        """Isotropic scale [px/m]: equals ``scale_x == scale_y`` when the aspect is kept, else the
        smaller of the two (the largest circle-preserving scale, e.g. for the robot's outline)."""
        return min(self.scale_x, self.scale_y)

    def map_rect_px(self) -> tuple[float, float, float, float]:
        """Where the map image goes in the widget: (left, top, width, height) [px]."""
        return (
            self.offset_x,
            self.offset_y,
            self.map_width_m * self.scale_x,
            self.map_height_m * self.scale_y,
        )

    def world_to_widget(self, x: float, y: float) -> tuple[float, float]:
        """Map-frame point [m] to widget pixels (y down):
        ``px = offset_x + (x - origin_x) * scale_x``, ``py = offset_y + (top - y) * scale_y``."""
        px = self.offset_x + (x - self.map_origin_x) * self.scale_x
        py = self.offset_y + (self.map_top_y - y) * self.scale_y
        return (px, py)

    def yaw_to_widget_angle(self, yaw: float) -> float:
        """World yaw [rad, CCW from +x] to a widget angle [rad] from +x towards +y (clockwise on
        screen), in (-pi, pi]. With an isotropic scale this is ``-yaw`` wrapped; with a stretched
        view the direction is scaled per axis too: ``atan2(-sin(yaw) * sy, cos(yaw) * sx)``."""
        if not math.isfinite(yaw):
            raise MapViewError(f"yaw must be finite, got {yaw!r}")
        angle = math.atan2(-math.sin(yaw) * self.scale_y, math.cos(yaw) * self.scale_x)
        return math.pi if angle == -math.pi else angle
