"""The robot's camera stream beside the map (thesis §4.1.2: "the Camera stream").

A `QLabel` showing the newest JPEG frame, decoded with ``QImage.fromData`` only when a new
frame arrived (checked on the controller's 25 ms ``frame_ready``).
"""

from __future__ import annotations

import logging

from PySide6.QtCore import Qt
from PySide6.QtGui import QImage, QPixmap, QResizeEvent
from PySide6.QtWidgets import QLabel, QSizePolicy, QWidget

from base_station_app.station_controller import StationController

logger = logging.getLogger(__name__)


class QtCameraView(QLabel):
    """Scaled camera frame, "no camera image" until the first one."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__("no camera image", parent)
        self._controller = controller
        self._version = -1
        self._image = QImage()
        self.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setMinimumSize(160, 120)
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.setStyleSheet("background: #202020; color: #c0c0c0;")
        controller.frame_ready.connect(self.refresh)

    @property
    def image(self) -> QImage:
        return self._image

    def refresh(self) -> None:
        state = self._controller.state
        if state.image is None or state.image_version == self._version:
            return
        self._version = state.image_version
        image = QImage.fromData(state.image.jpeg)
        if image.isNull():
            logger.warning("camera frame is not a decodable JPEG")
            return
        self._image = image
        self._show()

    def _show(self) -> None:
        if not self._image.isNull():
            self.setPixmap(
                QPixmap.fromImage(self._image).scaled(
                    self.size(),
                    Qt.AspectRatioMode.KeepAspectRatio,
                    Qt.TransformationMode.SmoothTransformation,
                )
            )

    def resizeEvent(self, event: QResizeEvent) -> None:
        super().resizeEvent(event)
        self._show()
