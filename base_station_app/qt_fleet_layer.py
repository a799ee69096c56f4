"""Every robot on the station's map (issue 14): footprint, name label and planned path.

The selected robot is drawn by the map view itself (with its laser scan, route markers and
goal); this layer adds, for EVERY robot the station has seen, a label with its name and state,
and for the others their footprint and the path their navigator planned. Colours say the state
(`HEALTH_COLOURS`: ok / degraded / lost / stopped / offline, the last drawn at the last known
pose). It draws `RobotView` snapshots from the controller and holds no robot state itself;
`robot_at` lets a click on a robot select it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import pyqtgraph as pg
from PySide6.QtCore import Qt

from base_station_app.robot_mirror import Health, RobotView
from interbot_core.geometry import Pose2D

Footprint = Callable[[Pose2D], npt.NDArray[np.float64]]

HEALTH_COLOURS: dict[Health, tuple[int, int, int]] = {
    Health.OK: (0, 140, 0),
    Health.DEGRADED: (200, 170, 0),
    Health.LOST: (200, 120, 0),
    Health.STOPPED: (200, 0, 0),
    Health.OFFLINE: (120, 120, 120),
}
CLICK_RADIUS_M = 0.6  # [m] a click this close to a robot's centre selects it


class QtFleetLayer:
    """Items for every robot, added to ``plot`` once per robot and updated with ``setData``."""

    def __init__(
        self, plot: pg.PlotItem, footprint: Footprint, radius: float, z: float = 4.0
    ) -> None:
        self._plot = plot
        self._footprint = footprint  # the map view's robot shape, as (x, y) rows
        self._radius = radius
        self._z = z
        self._items: dict[str, tuple[pg.PlotCurveItem, pg.PlotCurveItem, pg.TextItem]] = {}
        self._keys: dict[str, tuple[object, ...]] = {}
        self.views: list[RobotView] = []

    def add_legend(self, legend: pg.LegendItem) -> None:
        """One legend row: "robot" and its state colours, each word in its colour."""
        words = " ".join(
            f'<span style="color: rgb{HEALTH_COLOURS[h]}; font-weight: bold">{h}</span>'
            for h in (Health.DEGRADED, Health.LOST, Health.STOPPED, Health.OFFLINE)
        )
        ok = HEALTH_COLOURS[Health.OK]
        legend.addItem(
            pg.PlotDataItem(pen=pg.mkPen(ok, width=3)),
            f'robot <span style="color: rgb{ok}; font-weight: bold">ok</span> {words}',
        )

    def _items_for(self, robot_id: str) -> tuple[pg.PlotCurveItem, pg.PlotCurveItem, pg.TextItem]:
        items = self._items.get(robot_id)
        if items is None:
            body = pg.PlotCurveItem(connect="finite")
            path = pg.PlotCurveItem(pen=pg.mkPen((30, 110, 220, 150), width=2))
            label = pg.TextItem("", anchor=(0.5, 1.4))
            for item in (path, body, label):
                item.setZValue(self._z)
                self._plot.addItem(item)
            label.setZValue(self._z + 1)
            items = self._items[robot_id] = (body, path, label)
        return items

    def redraw(self, views: list[RobotView]) -> None:
        self.views = views
        for view in views:
            if self._keys.get(view.robot_id) == view.key:
                continue
            self._keys[view.robot_id] = view.key
            body, path, label = self._items_for(view.robot_id)
            colour = HEALTH_COLOURS[view.health]
            if view.pose is None:
                body.setData([], [])
                path.setData([], [])
                label.setText("")
                continue
            pen = pg.mkPen(colour, width=3)
            if view.health is Health.OFFLINE:
                pen.setStyle(Qt.PenStyle.DashLine)
            body.setPen(pen)
            if view.selected:
                body.setData([], [])  # the map view draws the selected robot with its scan
                path.setData([], [])
            else:
                xy = self._footprint(view.pose)
                body.setData(xy[:, 0], xy[:, 1])
                if view.plan:
                    pts = np.vstack(([[view.pose.x, view.pose.y]], np.array(view.plan)))
                    path.setData(pts[:, 0], pts[:, 1])
                else:
                    path.setData([], [])
            mark = "▶ " if view.selected else ""
            label.setText(f"{mark}{view.robot_id}: {view.health}")
            label.setColor(pg.mkColor(255, 255, 255))
            label.fill = pg.mkBrush(*colour, 220)
            label.update()
            label.setPos(view.pose.x, view.pose.y)

    def robot_at(self, x: float, y: float) -> str | None:
        """The robot drawn nearest (within `CLICK_RADIUS_M`) to map point (x, y) [m]."""
        best, best_d = None, max(CLICK_RADIUS_M, self._radius)
        for view in self.views:
            if view.pose is None:
                continue
            d = math.hypot(view.pose.x - x, view.pose.y - y)
            if d <= best_d:
                best, best_d = view.robot_id, d
        return best
