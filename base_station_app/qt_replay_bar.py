"""The replay bar under the map: play/pause, speed ×0.5–×20 and a time slider for a replayed robot.

Shown only while the selected robot is a replay (``interbot replay FILE.mcap``), i.e. while its
`ReplayState` keeps arriving (`ReplayWatch`); hidden otherwise. It reads the state on the
controller's 25 ms ``frame_ready`` and forwards the user's input as `ReplayCommand` through a
`ReplayControlClient`; the slider follows the replay except while the user drags it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from PySide6.QtCore import QSignalBlocker, Qt
from PySide6.QtWidgets import QComboBox, QHBoxLayout, QLabel, QPushButton, QSlider, QWidget

from base_station_app.station_controller import StationController
from interbot_core.replay_control import ReplayCommand, ReplayState, ReplayWatch
from interbot_link.replay import ReplayControlClient

SPEEDS = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
TICKS_PER_S = 10  # slider resolution: 0.1 s


def _clock_text(seconds: float) -> str:
    minutes, secs = divmod(int(seconds), 60)
    return f"{minutes:02d}:{secs:02d}"


class QtReplayBar(QWidget):
    """Play/pause, speed and position of the selected robot's replay."""

    def __init__(
        self,
        controller: StationController,
        client: ReplayControlClient | None,
        clock: Callable[[], float] = time.monotonic,
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self._controller = controller
        self._client = client
        self._clock = clock
        self._watch = ReplayWatch()
        self.replay_state: ReplayState | None = None
        self.play_button = QPushButton("Play")
        self.play_button.setToolTip("Play or pause the replay")
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setToolTip("Recording time: drag to seek")
        self.time_label = QLabel("00:00 / 00:00")
        self.speed_box = QComboBox()
        for speed in SPEEDS:
            self.speed_box.addItem(f"×{speed:g}", speed)
        self.speed_box.setToolTip("Replay speed")
        self.source_label = QLabel()
        layout = QHBoxLayout(self)
        layout.setContentsMargins(4, 2, 4, 2)
        layout.addWidget(QLabel("Replay"))
        layout.addWidget(self.play_button)
        layout.addWidget(self.slider, 1)
        layout.addWidget(self.time_label)
        layout.addWidget(self.speed_box)
        layout.addWidget(self.source_label)
        self.play_button.clicked.connect(self.toggle_play)
        self.slider.sliderReleased.connect(self.seek_to_slider)
        self.speed_box.activated.connect(self.set_speed_index)
        controller.frame_ready.connect(self.refresh)
        self.hide()

    def refresh(self) -> None:
        if self._client is not None:
            self._watch.update(self._client.poll_states(), self._clock())
        state = self._watch.state(self._controller.selected_robot, self._clock())
        self.replay_state = state
        self.setVisible(state is not None)
        if state is None:
            return
        self.play_button.setText("Pause" if state.playing else "Play")
        if not self.slider.isSliderDown():
            with QSignalBlocker(self.slider):
                self.slider.setRange(0, round(state.duration * TICKS_PER_S))
                self.slider.setValue(round(state.position * TICKS_PER_S))
        self.time_label.setText(f"{_clock_text(state.position)} / {_clock_text(state.duration)}")
        index = self.speed_box.findData(state.speed)
        if index >= 0 and not self.speed_box.view().isVisible():
            with QSignalBlocker(self.speed_box):
                self.speed_box.setCurrentIndex(index)
        self.source_label.setText(state.source)

    def _send(self, command: ReplayCommand) -> None:
        robot = self._controller.selected_robot
        if self._client is not None and robot is not None:
            self._client.send(robot, command)

    def toggle_play(self) -> None:
        playing = self.replay_state is not None and self.replay_state.playing
        self._send(ReplayCommand("pause" if playing else "play"))

    def seek_to_slider(self) -> None:
        self._send(ReplayCommand("seek", self.slider.value() / TICKS_PER_S))

    def set_speed_index(self, index: int) -> None:
        self._send(ReplayCommand("speed", float(self.speed_box.itemData(index))))
