"""The robot's camera stream beside the map (thesis §4.1.2: "the Camera stream").

A `QLabel` showing the newest JPEG frame, decoded with ``QImage.fromData`` only when a new
frame arrived (checked on the controller's 25 ms ``frame_ready``).
"""

from __future__ import annotations

import logging

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QImage, QPixmap, QResizeEvent
from PySide6.QtWidgets import QLabel, QSizePolicy, QWidget

from base_station_app.station_controller import StationController

logger = logging.getLogger(__name__)


class QtCameraView(QLabel):
    """Scaled camera frame, "no camera image" until the first one.

    ``aspect_changed(width / height)`` is emitted when the first frame (or a frame of another
    shape) arrives, so the window can give the pane the image's shape instead of black bars.
    """

    aspect_changed = Signal(float)

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__("no camera image", parent)
        self._controller = controller
        self._version = -1
        self.image = QImage()
        self.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setMinimumSize(160, 120)
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.setStyleSheet("color: #606060;")
        controller.frame_ready.connect(self.refresh)

    def refresh(self) -> None:
        state = self._controller.selected.state
        if state.image is None or state.image_version == self._version:
            return
        self._version = state.image_version
        image = QImage.fromData(state.image.jpeg)
        if image.isNull():
            logger.warning("camera frame is not a decodable JPEG")
            return
        aspect = image.width() / image.height()
        if self.image.isNull() or abs(aspect - self.aspect) > 1e-3:
            self.image = image
            self.aspect_changed.emit(aspect)
        self.image = image
        self._show()

    @property
    def aspect(self) -> float:
        """Width / height of the newest frame (4:3 before the first)."""
        return 4 / 3 if self.image.isNull() else self.image.width() / self.image.height()

    def _show(self) -> None:
        if not self.image.isNull():
            self.setPixmap(
                QPixmap.fromImage(self.image).scaled(
                    self.size(),
                    Qt.AspectRatioMode.KeepAspectRatio,
                    Qt.TransformationMode.SmoothTransformation,
                )
            )

    def resizeEvent(self, event: QResizeEvent) -> None:
        super().resizeEvent(event)
        self._show()
