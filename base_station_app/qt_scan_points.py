"""The laser scan on the station's map as plain points, drawn in one `QPainter.drawPoints` call.

Issue 14: the map view ran on the Qt thread that also forwards the tablet's commands, and a
`pyqtgraph.ScatterPlotItem` of ~1000 spots cost several milliseconds a frame (per-spot records,
symbol atlas, bounds). The scan needs none of that: one colour, one size, no per-point
interaction. `ScanPointsItem` keeps the points in a `QPolygonF` filled from numpy (no Python
loop) and paints them with a cosmetic square pen (``size`` pixels at any zoom), as the scatter
did with ``pxMode=True``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pyqtgraph as pg
import pyqtgraph.functions as fn
from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QStyleOptionGraphicsItem, QWidget

FloatArray = npt.NDArray[np.float64]


class ScanPointsItem(pg.GraphicsObject):  # type: ignore[misc]
    """Points (x, y) in view coordinates, ``size`` pixels square; NaN points are not drawn."""

    def __init__(self, color: tuple[int, int, int] = (220, 30, 30), size: float = 3.0) -> None:
        super().__init__()
        self._pen = QPen(QColor(*color))
        self._pen.setWidthF(size)
        self._pen.setCosmetic(True)  # pixels, whatever the zoom
        self._pen.setCapStyle(Qt.PenCapStyle.SquareCap)
        self._polygon = QPolygonF()
        self._xs: FloatArray = np.zeros(0)
        self._ys: FloatArray = np.zeros(0)
        self._bounds = QRectF()

    def setData(self, xs: npt.ArrayLike, ys: npt.ArrayLike) -> None:
        x = np.asarray(xs, dtype=np.float64).ravel()
        y = np.asarray(ys, dtype=np.float64).ravel()
        if x.shape != y.shape:
            raise ValueError(f"scan points: {x.size} x values but {y.size} y values")
        keep = np.isfinite(x) & np.isfinite(y)
        x, y = x[keep], y[keep]
        self.prepareGeometryChange()
        self._xs, self._ys = x, y
        polygon = fn.create_qpolygonf(x.size)
        if x.size:
            view = fn.ndarray_from_qpolygonf(polygon)
            view[:, 0] = x
            view[:, 1] = y
            self._bounds = QRectF(
                float(x.min()), float(y.min()), float(np.ptp(x)), float(np.ptp(y))
            )
        else:
            self._bounds = QRectF()
        self._polygon = polygon
        self.update()

    def getData(self) -> tuple[FloatArray, FloatArray]:
        """The drawn points (finite ones only)."""
        return self._xs, self._ys

    def __len__(self) -> int:
        return int(self._xs.size)

    def boundingRect(self) -> QRectF:
        if self._bounds.isNull() and not self._xs.size:
            return QRectF()
        # The points' own extent plus their size in pixels (a cosmetic pen), in view units.
        px = self.pixelLength(pg.Point(1, 0)) or 0.0
        py = self.pixelLength(pg.Point(0, 1)) or 0.0
        m = self._pen.widthF()
        return self._bounds.adjusted(-m * px, -m * py, m * px, m * py)

    def dataBounds(
        self, ax: int, frac: float = 1.0, orthoRange: object = None
    ) -> tuple[float, float] | tuple[None, None]:
        data = self._xs if ax == 0 else self._ys
        if not data.size:
            return None, None
        return float(data.min()), float(data.max())

    def paint(
        self,
        painter: QPainter,
        option: QStyleOptionGraphicsItem,
        widget: QWidget | None = None,
    ) -> None:
        if self._polygon.isEmpty():
            return
        painter.setPen(self._pen)
        painter.drawPoints(self._polygon)
