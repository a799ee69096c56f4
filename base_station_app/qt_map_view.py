"""The station's map view (thesis §4.2.2.1: RViz's map, scan and pose, plus §5.3 "Tasks").

pyqtgraph, as FIELD_NOTES recommends for 40 Hz: the occupancy grid is one row-major uint8
`ImageItem` with fixed levels placed with ``setRect`` (row 0 at the bottom of the y-up view),
the laser scan as points in the map frame placed from the pose at the scan's own time (a
polyline's chords would cut through walls, and the newest pose would smear it while turning),
the robot a footprint polygon with a heading line, the path the robot's navigator planned (as it
published it) with the route's intermediate goals as markers and the current one highlighted,
the topological nodes with room labels, the tour stops (visited green, next red), and a legend. Items are created once and updated with ``setData`` from the controller's
``frame_ready`` (15 Hz, coalesced: issue 14), only when something changed; the scan is a
`ScanPointsItem` (one ``drawPoints``), not a scatter of ~1000 spots.

Input: a click inside a room emits ``room_clicked(node)``; in a pick mode (``goal`` or
``initial``) a press sets a point and dragging sets the heading, drawn as an arrow, and the
release emits ``pose_picked(mode, Pose2D)``. While the view has focus the arrow keys and WASD
teleoperate (auto-repeat ignored) and losing focus releases them.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import numpy.typing as npt
import pyqtgraph as pg
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QFocusEvent, QFont, QKeyEvent, QMouseEvent
from PySide6.QtWidgets import QGraphicsItem, QWidget

from base_station_app.map_labels import SNAP_RADIUS, MapLabel, map_labels
from base_station_app.qt_fleet_layer import HEALTH_COLOURS, QtFleetLayer
from base_station_app.qt_scan_points import ScanPointsItem
from base_station_app.station_controller import StationController
from base_station_app.teleop import Direction
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import INTERBOT_LASER_MOUNT
from interbot_core.map_image import grey_image
from interbot_core.occupancy_grid import OccupancyGrid

logger = logging.getLogger(__name__)

TELEOP_KEYS = {
    Qt.Key.Key_Up: Direction.FORWARD,
    Qt.Key.Key_W: Direction.FORWARD,
    Qt.Key.Key_Down: Direction.BACKWARD,
    Qt.Key.Key_S: Direction.BACKWARD,
    Qt.Key.Key_Left: Direction.LEFT,
    Qt.Key.Key_A: Direction.LEFT,
    Qt.Key.Key_Right: Direction.RIGHT,
    Qt.Key.Key_D: Direction.RIGHT,
}

_STATIC = QGraphicsItem.CacheMode.DeviceCoordinateCache
ROBOT_RADIUS = 0.3  # [m] footprint drawn for Interbot (a round base)
CLICK_SLOP_PX = 5.0
LABEL_POINT_SIZE = 10  # readable at 1280 x 800 and 2560 x 1600 alike


def footprint_xy(
    pose: Pose2D, radius: float = ROBOT_RADIUS, n: int = 24
) -> npt.NDArray[np.float64]:
    """Closed circle around the robot plus a heading line from its centre, as (x, y) rows."""
    t = np.linspace(0.0, 2 * math.pi, n + 1)
    circle = np.column_stack((pose.x + radius * np.cos(t), pose.y + radius * np.sin(t)))
    tip = (pose.x + 1.6 * radius * math.cos(pose.yaw), pose.y + 1.6 * radius * math.sin(pose.yaw))
    heading = np.array([[math.nan, math.nan], [pose.x, pose.y], tip])
    return np.vstack((circle, heading))


def scan_xy(
    pose: Pose2D, angles: npt.NDArray[np.float64], ranges: npt.NDArray[np.float32]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """End points of the beams (``angles``, ``ranges``: the valid ones) in the map frame."""
    r = ranges.astype(np.float64)
    a = angles + pose.yaw
    return pose.x + r * np.cos(a), pose.y + r * np.sin(a)


def arrow_xy(x: float, y: float, yaw: float, length: float) -> npt.NDArray[np.float64]:
    tip = (x + length * math.cos(yaw), y + length * math.sin(yaw))
    head = 0.3 * length
    left = (tip[0] - head * math.cos(yaw - 0.5), tip[1] - head * math.sin(yaw - 0.5))
    right = (tip[0] - head * math.cos(yaw + 0.5), tip[1] - head * math.sin(yaw + 0.5))
    return np.array([[x, y], tip, left, [math.nan, math.nan], tip, right])


class QtMapView(pg.PlotWidget):
    """Map, scan, robot, route and topological nodes; room clicks, pose picks, teleop keys."""

    room_clicked = Signal(int)
    pose_picked = Signal(str, object)  # mode ("goal" / "initial"), Pose2D
    pick_mode_changed = Signal(str)

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent, background=(235, 235, 235))
        self._controller = controller
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)
        self.setAspectLocked(True)
        self.showGrid(x=False, y=False)
        self.setLabel("bottom", "x [m]")
        self.setLabel("left", "y [m]")
        self.setMenuEnabled(False)
        self._pick_mode = ""
        self._press_pos: QPointF | None = None
        self._pick_start: tuple[float, float] | None = None
        self._drawn_key: object = None
        self._grid: OccupancyGrid | None = None
        self._create_items()
        self._draw_topology()
        controller.frame_ready.connect(self.redraw)
        controller.tasks_changed.connect(self._invalidate)
        controller.route_sent.connect(self._invalidate)
        self.redraw()
        self.fit_map()

    # ------------------------------------------------------------------ items
    def _create_items(self) -> None:
        plot = self.getPlotItem()
        self.map_item = pg.ImageItem(axisOrder="row-major")
        self.map_item.setZValue(-10)
        plot.addItem(self.map_item)
        self.rooms_item = pg.PlotCurveItem(pen=pg.mkPen((120, 160, 220), width=1), connect="finite")
        plot.addItem(self.rooms_item)
        self.nodes_item = pg.ScatterPlotItem(size=7, brush=pg.mkBrush(90, 90, 90), pen=None)
        plot.addItem(self.nodes_item)
        self.tour_item = pg.ScatterPlotItem(size=12, pen=pg.mkPen("k"))
        plot.addItem(self.tour_item)
        self.route_item = pg.PlotCurveItem(pen=pg.mkPen((30, 110, 220), width=3))
        plot.addItem(self.route_item)
        self.waypoints_item = pg.ScatterPlotItem(size=9, pen=pg.mkPen("w"))
        plot.addItem(self.waypoints_item)
        self.goal_item = pg.ScatterPlotItem(
            size=18, symbol="star", brush=pg.mkBrush(255, 140, 0), pen=pg.mkPen("k")
        )
        plot.addItem(self.goal_item)
        self.scan_item = ScanPointsItem((220, 30, 30), size=3.0)  # cheap: one drawPoints
        plot.addItem(self.scan_item)
        self.robot_item = pg.PlotCurveItem(pen=pg.mkPen((0, 140, 0), width=3), connect="finite")
        plot.addItem(self.robot_item)
        self.pick_item = pg.PlotCurveItem(pen=pg.mkPen((200, 0, 200), width=3), connect="finite")
        plot.addItem(self.pick_item)
        self.fleet_layer = QtFleetLayer(plot, footprint_xy, ROBOT_RADIUS)  # every robot (#14)
        self._create_legend(plot)
        # What rarely changes is painted from a pixmap cache (re-rendered on zoom, pan or a
        # change): less drawing on the Qt thread that also forwards the tablet's commands.
        for item in (self.map_item, self.rooms_item, self.nodes_item, self.legend):
            item.setCacheMode(_STATIC)
        self.labels: list[pg.TextItem] = []
        self._label_font = QFont()
        self._label_font.setPointSize(LABEL_POINT_SIZE)
        self._label_specs: list[MapLabel] = []
        self._label_widths: list[float] = []  # [px] each label's full text

    def _create_legend(self, plot: pg.PlotItem) -> None:
        """What each mark means, in the corner: robot, scan, planned path, goals, tour."""
        legend = plot.addLegend(offset=(-8, -8), labelTextSize="9pt", brush=(255, 255, 255, 210))
        self.fleet_layer.add_legend(legend)  # robot: its state colours (issue 14)
        legend.addItem(
            pg.ScatterPlotItem(size=6, pen=None, brush=pg.mkBrush(220, 30, 30)), "laser scan"
        )
        legend.addItem(pg.PlotDataItem(pen=pg.mkPen((30, 110, 220), width=3)), "planned path")
        legend.addItem(
            pg.ScatterPlotItem(size=12, symbol="star", brush=pg.mkBrush(255, 140, 0)),
            "current goal",
        )
        legend.addItem(pg.ScatterPlotItem(size=10, brush=pg.mkBrush(0, 170, 0)), "tour: visited")
        legend.addItem(pg.ScatterPlotItem(size=10, brush=pg.mkBrush(220, 0, 0)), "tour: next")
        self.legend = legend

    def _draw_topology(self) -> None:
        c = self._controller
        xy = np.array([[n.pose.x, n.pose.y] for n in c.topo.nodes])
        self.nodes_item.setData(pos=xy)
        self._place_labels(c.grid)
        outlines = [r.area for r in c.rooms.rooms if r.explicit]
        polys = [[*area, area[0], (math.nan, math.nan)] for area in outlines]
        if polys:
            pts = np.array([pt for poly in polys for pt in poly], dtype=np.float64)
            self.rooms_item.setData(pts[:, 0], pts[:, 1])
        self.getPlotItem().vb.sigRangeChanged.connect(self._fit_labels)

    def _place_labels(self, grid: OccupancyGrid | None) -> None:
        """Room labels on each room's clearest floor (off the furniture) once the map is known."""
        for label in self.labels:
            self.removeItem(label)
        self.labels.clear()
        c = self._controller
        rooms = c.rooms if grid is None else c.rooms.with_labels(grid)
        self._label_specs = map_labels(rooms)
        for spec in self._label_specs:
            label = pg.TextItem(
                spec.text,
                color=(30, 30, 30),
                anchor=(0.5, 0.5),
                fill=pg.mkBrush(255, 255, 255, 200),
            )
            label.setFont(self._label_font)
            label.setPos(spec.x, spec.y)
            label.setZValue(5)
            label.setCacheMode(_STATIC)
            self.addItem(label)
            self.labels.append(label)
        self._label_widths = [label.textItem.boundingRect().width() for label in self.labels]
        self._fit_labels()

    def _fit_labels(self, *args: object) -> None:
        """The room's name where it fits on screen at this zoom, else just its number."""
        vb = self.getPlotItem().vb
        (x0, x1), _ = vb.viewRange()
        px_per_m = vb.width() / (x1 - x0) if x1 > x0 else 0.0
        for label, spec, full_px in zip(
            self.labels, self._label_specs, self._label_widths, strict=True
        ):
            text = spec.text if spec.width * px_per_m >= full_px else spec.short
            if label.toPlainText() != text:
                label.setText(text)

    def fit_map(self) -> None:
        grid = self._controller.grid
        if grid is not None:
            w, h = grid.size_m
            self.setRange(QRectF(grid.origin_x, grid.origin_y, w, h), padding=0.02)

    def _invalidate(self, *args: object) -> None:
        self._drawn_key = None

    # ------------------------------------------------------------------ drawing
    def redraw(self) -> None:
        c = self._controller
        grid = c.grid
        if grid is not None and (grid is not self._grid):
            first = self._grid is None or self._grid.size_m != grid.size_m
            self._grid = grid
            self.map_item.setImage(grey_image(grid), levels=(0, 255), autoLevels=False)
            w, h = grid.size_m
            self.map_item.setRect(QRectF(grid.origin_x, grid.origin_y, w, h))
            if first:
                self._place_labels(grid)
                self.fit_map()
        self.fleet_layer.redraw(c.fleet.views(c.names))
        sup = c.selected.supervisor
        key = (
            c.selected.health,
            c.selected.state.version,
            id(c.selected.route),
            sup.route_index,
            sup.visited_tour_stops,
            sup.tour_stops,
        )
        if key == self._drawn_key:
            return
        self._drawn_key = key
        self._draw_robot()
        self._draw_route()
        self._draw_tour()

    def _draw_robot(self) -> None:
        state = self._controller.selected.state
        pose_msg = state.pose
        if pose_msg is None or not pose_msg.known:
            self.robot_item.setData([], [])
            self.scan_item.setData([], [])
            return
        pose = Pose2D(pose_msg.x, pose_msg.y, pose_msg.yaw)
        pen = HEALTH_COLOURS[self._controller.selected.health]  # the fleet's colours (#14)
        self.robot_item.setPen(pg.mkPen(pen, width=3))
        xy = footprint_xy(pose)
        self.robot_item.setData(xy[:, 0], xy[:, 1])
        scan, scan_pose = state.scan, state.scan_pose()
        if scan is None or scan_pose is None:
            self.scan_item.setData([], [])
        else:
            laser = scan_pose.compose(INTERBOT_LASER_MOUNT)
            valid = scan.valid()
            xs, ys = scan_xy(laser, scan.angles[valid], scan.ranges[valid])
            self.scan_item.setData(xs, ys)

    def _draw_route(self) -> None:
        c = self._controller
        route = c.selected.route if c.selected.supervisor.current_task is not None else None
        if route is None:
            self.route_item.setData([], [])
            self.waypoints_item.setData([])
            self.goal_item.setData([])
            return
        wps = np.array([[w[0], w[1]] for w in route.waypoints])
        pose = c.selected.state.localised_pose
        index = c.selected.supervisor.route_index
        index = c.selected.route_index if index is None else index
        index = min(index, len(wps) - 1)
        plan = c.selected.state.plan
        if plan is not None and plan.points and plan.route_id == route.route_id:
            pts = np.array(plan.points)
            if pose is not None:
                pts = np.vstack(([[pose.x, pose.y]], pts))
            self.route_item.setData(pts[:, 0], pts[:, 1])
        else:
            self.route_item.setData([], [])  # no plan yet: goals only, no lines through walls
        passed, ahead = pg.mkBrush(150, 150, 150), pg.mkBrush(30, 110, 220)
        self.waypoints_item.setData(
            pos=wps, brush=[passed if i < index else ahead for i in range(len(wps))]
        )
        self.goal_item.setData(pos=wps[index : index + 1])

    def _draw_tour(self) -> None:
        sup = self._controller.selected.supervisor
        stops = sup.tour_stops
        if not stops:
            self.tour_item.setData([])
            return
        topo = self._controller.topo
        visited = set(sup.visited_tour_stops)
        nxt = sup.next_tour_stop
        spots = []
        for s in stops:
            node = topo.nodes[s]
            color = (0, 170, 0) if s in visited else (220, 0, 0) if s == nxt else (250, 220, 60)
            spots.append({"pos": (node.pose.x, node.pose.y), "brush": pg.mkBrush(*color)})
        self.tour_item.setData(spots)

    # ------------------------------------------------------------------ picking
    def set_pick_mode(self, mode: str) -> None:
        """ "goal", "initial" or "" (pan and room clicks)."""
        if mode not in ("", "goal", "initial"):
            raise ValueError(f"unknown pick mode {mode!r}")
        self._pick_mode = mode
        self._pick_start = None
        self.pick_item.setData([], [])
        self.setCursor(Qt.CursorShape.CrossCursor if mode else Qt.CursorShape.ArrowCursor)
        self.pick_mode_changed.emit(mode)

    def map_point(self, pos: QPointF) -> tuple[float, float]:
        """Widget position [px] to map coordinates [m]."""
        p = self.getPlotItem().vb.mapSceneToView(self.mapToScene(pos.toPoint()))
        return float(p.x()), float(p.y())

    def mousePressEvent(self, event: QMouseEvent) -> None:
        self.setFocus(Qt.FocusReason.MouseFocusReason)
        if event.button() == Qt.MouseButton.LeftButton:
            self._press_pos = event.position()
            if self._pick_mode:
                self._pick_start = self.map_point(event.position())
                event.accept()
                return
        super().mousePressEvent(event)

    def mouseMoveEvent(self, event: QMouseEvent) -> None:
        if self._pick_mode and self._pick_start is not None:
            x0, y0 = self._pick_start
            x, y = self.map_point(event.position())
            yaw = math.atan2(y - y0, x - x0)
            length = max(0.8, math.hypot(x - x0, y - y0))
            xy = arrow_xy(x0, y0, yaw, length)
            self.pick_item.setData(xy[:, 0], xy[:, 1])
            event.accept()
            return
        super().mouseMoveEvent(event)

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:
        if event.button() != Qt.MouseButton.LeftButton:
            super().mouseReleaseEvent(event)
            return
        press, self._press_pos = self._press_pos, None
        if self._pick_mode and self._pick_start is not None:
            x0, y0 = self._pick_start
            x, y = self.map_point(event.position())
            dragged = (
                math.hypot(x - x0, y - y0) > 1e-6
                and press is not None
                and ((event.position() - press).manhattanLength() > CLICK_SLOP_PX)
            )
            yaw = math.atan2(y - y0, x - x0) if dragged else 0.0
            mode = self._pick_mode
            self.set_pick_mode("")
            self.pose_picked.emit(mode, Pose2D(x0, y0, yaw))
            event.accept()
            return
        super().mouseReleaseEvent(event)
        if press is not None and (event.position() - press).manhattanLength() <= CLICK_SLOP_PX:
            x, y = self.map_point(event.position())
            robot = self.fleet_layer.robot_at(x, y)  # a click on a robot commands it (#14)
            if robot is not None and robot != self._controller.selected_robot:
                self._controller.select_robot(robot)
                return
            room = self._controller.rooms.room_at(x, y, SNAP_RADIUS)
            if room is not None:
                self.room_clicked.emit(room.id)

    # ------------------------------------------------------------------ keys
    def keyPressEvent(self, event: QKeyEvent) -> None:
        direction = TELEOP_KEYS.get(Qt.Key(event.key()))
        if direction is None:
            if event.key() == Qt.Key.Key_Escape and self._pick_mode:
                self.set_pick_mode("")
                return
            super().keyPressEvent(event)
            return
        if not event.isAutoRepeat():
            self._controller.press(direction)
        event.accept()

    def keyReleaseEvent(self, event: QKeyEvent) -> None:
        direction = TELEOP_KEYS.get(Qt.Key(event.key()))
        if direction is None:
            super().keyReleaseEvent(event)
            return
        if not event.isAutoRepeat():
            self._controller.release(direction)
        event.accept()

    def focusOutEvent(self, event: QFocusEvent) -> None:
        self._controller.release_all()
        super().focusOutEvent(event)
