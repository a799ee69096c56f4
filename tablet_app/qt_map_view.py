"""Interactive floor map of the Tablet (thesis §5.2.1, Algorithm 3, Fig. 5.6, Fig. 6.2a).

Draws the occupancy grid of the floor, each room of the topological map (outline and label),
and the robot as a red circle with a heading mark placed by
`interbot_core.map_view_transform.MapViewTransform` (Algorithm 3 generalised: aspect kept, y
flipped so north is up). Each room's area is a transparent button; a `QSignalMapper` maps
every button to its node id, as in the thesis (Fig. 5.6, ``clickedGoal``), and the view emits
``room_clicked(node_id)``. Rooms are coloured by state: guided-tour stops visited (green), the
next one (red), and, while the user is helping the robot localise (§5.2.2.1), highlighted
(yellow).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from PySide6.QtCore import QPointF, QRect, QRectF, QSignalMapper, Qt, Signal
from PySide6.QtGui import (
    QColor,
    QFont,
    QFontMetrics,
    QImage,
    QPainter,
    QPaintEvent,
    QPen,
    QResizeEvent,
)
from PySide6.QtWidgets import QPushButton, QSizePolicy, QWidget

from interbot_core.map_image import grey_image
from interbot_core.map_view_transform import MapViewTransform
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.rooms import RoomMap

logger = logging.getLogger(__name__)

ROBOT_RADIUS_M = 0.35  # drawn size [m]; never smaller than a few pixels

_ROOM_COLOURS = {
    "normal": (QColor(40, 110, 210, 55), QColor(40, 110, 210, 200)),
    "visited": (QColor(0, 170, 0, 150), QColor(0, 120, 0, 255)),
    "next": (QColor(230, 20, 20, 160), QColor(170, 0, 0, 255)),
    "highlight": (QColor(255, 190, 0, 170), QColor(200, 130, 0, 255)),
}


def grid_to_qimage(grid: OccupancyGrid) -> QImage:
    """Occupancy grid to an 8-bit grey image, top row first: free white, occupied dark,
    unknown grey."""
    # The grid's row 0 is the bottom (lowest y); softer greys than the station's.
    grey = np.ascontiguousarray(grey_image(grid, free=250, occupied=40, unknown=205)[::-1])
    height, width = int(grey.shape[0]), int(grey.shape[-1])  # type: ignore[misc]
    image = QImage(grey.data, width, height, width, QImage.Format.Format_Grayscale8)
    return image.copy()  # own the pixels; ``grey`` goes away


class QtMapView(QWidget):
    """The floor, its rooms as touch targets, and the robot."""

    room_clicked = Signal(int)

    def __init__(
        self, plan: RoomMap, grid: OccupancyGrid | None = None, parent: QWidget | None = None
    ) -> None:
        super().__init__(parent)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setMinimumSize(200, 150)
        self._plan = plan
        self._image: QImage | None = None
        if grid is not None:
            self._image = grid_to_qimage(grid)
            self._world = (
                grid.origin_x,
                grid.origin_y,
                grid.width * grid.resolution,
                grid.height * grid.resolution,
            )
        else:
            x0, y0, x1, y1 = plan.bounds()
            margin = 1.0
            self._world = (x0 - margin, y0 - margin, x1 - x0 + 2 * margin, y1 - y0 + 2 * margin)
        self._transform = self._make_transform(400, 300)
        self._robot: tuple[float, float, float] | None = None
        self._visited: frozenset[int] = frozenset()
        self._next: int | None = None
        self._highlight = False
        self._min_touch = 44
        self._mapper = QSignalMapper(self)
        self._mapper.mappedInt.connect(self.room_clicked)
        self._buttons: dict[int, QPushButton] = {}
        for room in plan.rooms:
            button = QPushButton(self)
            button.setObjectName(f"room_{room.id}")
            button.setAccessibleName(room.name)
            button.setFocusPolicy(Qt.FocusPolicy.NoFocus)
            button.setFlat(True)
            button.setStyleSheet("QPushButton { background: transparent; border: none; }")
            button.clicked.connect(self._mapper.map)
            self._mapper.setMapping(button, room.id)
            self._buttons[room.id] = button
        self._place_buttons()

    # ---------------------------------------------------------------- public API
    @property
    def transform(self) -> MapViewTransform:
        return self._transform

    def room_button(self, room_id: int) -> QPushButton:
        return self._buttons[room_id]

    def room_state(self, room_id: int) -> str:
        """ "next", "visited", "highlight" or "normal" (the colour the room is drawn in)."""
        room = self._plan.room(room_id)
        if room.covers(self._next):
            return "next"
        if any(room.covers(node_id) for node_id in self._visited):
            return "visited"
        if self._highlight:
            return "highlight"
        return "normal"

    def robot_widget_pos(self) -> QPointF | None:
        """Where the robot is drawn [px], or None when its pose is unknown."""
        if self._robot is None:
            return None
        return QPointF(*self._transform.world_to_widget(self._robot[0], self._robot[1]))

    def set_robot_pose(self, x: float, y: float, yaw: float) -> None:
        self._robot = (x, y, yaw)
        self.update()

    def clear_robot(self) -> None:
        self._robot = None
        self.update()

    def set_tour(self, visited: frozenset[int] | set[int], next_room: int | None) -> None:
        self._visited = frozenset(visited)
        self._next = next_room
        self.update()

    def set_highlight(self, on: bool) -> None:
        """Highlight every room (the "Help me!" mode: drive me to one of these)."""
        self._highlight = on
        self.update()

    def set_plan(self, plan: RoomMap) -> None:
        """The same rooms with other texts (the UI language changed)."""
        if [r.id for r in plan.rooms] != list(self._buttons):
            raise ValueError("set_plan takes the same rooms in other words, not another plan")
        self._plan = plan
        for room in plan.rooms:
            self._buttons[room.id].setAccessibleName(room.name)
        self.update()

    def set_min_touch(self, px: int) -> None:
        self._min_touch = px
        self._place_buttons()

    # ---------------------------------------------------------------- geometry
    def _make_transform(self, width: float, height: float) -> MapViewTransform:
        x0, y0, w, h = self._world
        return MapViewTransform(x0, y0, w, h, max(1.0, width), max(1.0, height))

    def room_rect(self, room_id: int) -> QRectF:
        """The room's area in widget pixels."""
        x0, y0, x1, y1 = self._plan.room(room_id).bounds()
        left, top = self._transform.world_to_widget(x0, y1)
        right, bottom = self._transform.world_to_widget(x1, y0)
        return QRectF(QPointF(left, top), QPointF(right, bottom))

    def _place_buttons(self) -> None:
        for room_id, button in self._buttons.items():
            rect = self.room_rect(room_id)
            # Small rooms on small screens still get a finger-sized target.
            w = max(rect.width(), float(self._min_touch))
            h = max(rect.height(), float(self._min_touch))
            centre = rect.center()
            button.setGeometry(
                QRect(round(centre.x() - w / 2), round(centre.y() - h / 2), round(w), round(h))
            )

    def resizeEvent(self, event: QResizeEvent) -> None:
        self._transform = self._make_transform(self.width(), self.height())
        self._place_buttons()
        super().resizeEvent(event)

    # ---------------------------------------------------------------- painting
    def paintEvent(self, event: QPaintEvent) -> None:
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        painter.fillRect(self.rect(), QColor(60, 63, 68))
        map_rect = QRectF(*self._transform.map_rect_px())
        if self._image is not None:
            painter.drawImage(map_rect, self._image)
        else:
            painter.fillRect(map_rect, QColor(235, 235, 235))
        base_px = max(10, round(self._min_touch * 0.26))
        for room in self._plan.rooms:
            fill, outline = _ROOM_COLOURS[self.room_state(room.id)]
            rect = self.room_rect(room.id)
            painter.setPen(QPen(outline, 2.0))
            painter.setBrush(fill)
            painter.drawRect(rect)
            painter.setPen(QColor(15, 15, 15))
            painter.setFont(self._label_font(room.name, rect, base_px))
            painter.drawText(
                rect.adjusted(2, 2, -2, -2),
                Qt.AlignmentFlag.AlignCenter | Qt.TextFlag.TextWordWrap,
                room.name,
            )
        self._paint_robot(painter)
        painter.end()

    def _label_font(self, text: str, rect: QRectF, base_px: int) -> QFont:
        """The largest bold font up to ``base_px`` whose word-wrapped text fits ``rect``."""
        font = QFont(self.font())
        font.setBold(True)
        flags = Qt.AlignmentFlag.AlignCenter | Qt.TextFlag.TextWordWrap
        inner = rect.adjusted(2, 2, -2, -2).toRect()
        for px in range(base_px, 7, -1):
            font.setPixelSize(px)
            bounds = QFontMetrics(font).boundingRect(inner, int(flags), text)
            if bounds.width() <= inner.width() and bounds.height() <= inner.height():
                break
        return font

    def _paint_robot(self, painter: QPainter) -> None:
        if self._robot is None:
            return
        x, y, yaw = self._robot
        centre = QPointF(*self._transform.world_to_widget(x, y))
        radius = max(self._min_touch * 0.18, ROBOT_RADIUS_M * self._transform.scale)
        angle = self._transform.yaw_to_widget_angle(yaw)
        tip = QPointF(
            centre.x() + 2.0 * radius * math.cos(angle), centre.y() + 2.0 * radius * math.sin(angle)
        )
        painter.setPen(QPen(QColor(120, 0, 0), max(3.0, radius / 3.0)))
        painter.drawLine(centre, tip)
        painter.setPen(QPen(QColor(255, 255, 255), 2.0))
        painter.setBrush(QColor(225, 0, 0))
        painter.drawEllipse(centre, radius, radius)
