"""Tablet control (thesis §5.3 "Tablet Control", §5.3.4, §4.2.2.2).

Connection state and peer, the round-trip latency (average and a live plot of the last pings),
the watchdog (time since the last tablet speed command against the ceiling, commands
discarded), which kinds of tablet requests are allowed (sent to the tablet as ``permissions``)
and the tablet's current task, which the operator can take over, stop (pause) or cancel.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import (
    QCheckBox,
    QFormLayout,
    QGroupBox,
    QLabel,
    QVBoxLayout,
    QWidget,
)

from base_station_app.display_text import age_text
from base_station_app.station_controller import StationController
from base_station_app.tablet_policy import PERMISSION_KINDS, allows
from base_station_app.tablet_session import describe_task
from interbot_qt.layout import button, column, row

_TITLES = {
    "teleop": "Teleoperation (joystick)",
    "goals": "Goals and home",
    "tours": "Guided tours",
    "requests": "Requests / deliveries",
}


class QtTabletPanel(QWidget):
    """Connection, latency plot, watchdog, permissions, the tablet's task."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        layout = QVBoxLayout(self)
        conn = QGroupBox("Connection")
        form = QFormLayout(conn)
        self.state_label = QLabel()
        self.latency_label = QLabel()
        self.watchdog_label = QLabel()
        form.addRow("Tablet:", self.state_label)
        form.addRow("Round trip:", self.latency_label)
        form.addRow("Watchdog:", self.watchdog_label)
        layout.addWidget(conn)
        self.plot = pg.PlotWidget(background="w")
        self.plot.setLabel("left", "round trip [ms]")
        self.plot.setLabel("bottom", "ping #")
        self.plot.setMinimumHeight(140)
        self.latency_curve = self.plot.plot(pen=pg.mkPen((30, 110, 220), width=2))
        layout.addWidget(self.plot, 1)

        perms = QGroupBox("Allowed from the tablet")
        plo = QVBoxLayout(perms)
        self.permission_boxes: dict[str, QCheckBox] = {}
        for kind in PERMISSION_KINDS:
            box = QCheckBox(_TITLES[kind])
            box.setChecked(allows(controller.tablet_policy.permissions, kind))
            box.toggled.connect(lambda on, k=kind: controller.set_permission(k, on))
            plo.addWidget(box)
            self.permission_boxes[kind] = box
        layout.addWidget(perms)

        task = QGroupBox("Tablet's task")
        self.task_label = QLabel("none")
        self.override_button = button("Take over", self._override)
        self.stop_button = button("Stop (pause)", controller.tablet_requests.stop_task)
        self.cancel_button = button("Cancel", controller.tablet_requests.cancel_task)
        buttons = row(self.override_button, self.stop_button, self.cancel_button)
        column(self.task_label, buttons, parent=task)
        layout.addWidget(task)
        if controller.tablet_auth is not None:  # TLS + pairing (issue 15)
            from base_station_app.qt_tablet_pairing import QtTabletPairing

            self.pairing = QtTabletPairing(controller.tablet_auth)
            layout.addWidget(self.pairing)

        self.latencies: deque[float] = deque(maxlen=300)  # [s] the plot's last round trips
        controller.tablet_link.changed.connect(self.refresh)
        controller.tasks_changed.connect(self.refresh)
        controller.tablet.latency_measured.connect(self._on_latency)
        controller.clocked.connect(self._refresh_watchdog)
        self.refresh()

    def refresh(self) -> None:
        c = self._controller
        t = c.tablet
        if t.is_connected:
            mode = "" if t.greeted else " (no hello: compatibility mode)"
            self.state_label.setText(f"connected from {t.peer}{mode}")
        else:
            self.state_label.setText(f"not connected (listening on port {t.port})")
        lat = list(self.latencies)
        self.latency_label.setText(
            "–"
            if not lat
            else f"average {np.mean(lat) * 1000:.2f} ms, last {lat[-1] * 1000:.2f} ms ({len(lat)} pings)"
        )
        for kind, box in self.permission_boxes.items():
            box.blockSignals(True)
            box.setChecked(allows(c.tablet_policy.permissions, kind))
            box.blockSignals(False)
        task = c.tablet_requests.task
        self.task_label.setText("none" if task is None else describe_task(task, c.names))
        for b in (self.override_button, self.stop_button, self.cancel_button):
            b.setEnabled(task is not None)
        self._refresh_watchdog()

    def _override(self) -> None:
        """The operator takes the tablet's task over: it continues as a station task."""
        if self._controller.tablet_requests.override():
            self.refresh()

    def _on_latency(self, rtt: float) -> None:
        self.latencies.append(rtt)
        values = np.array(self.latencies) * 1000.0
        self.latency_curve.setData(np.arange(values.size), values)
        self.refresh()

    def _refresh_watchdog(self) -> None:
        c = self._controller
        latency = c.arbiter.watchdog.latency(c.clock())
        since = (
            "no speed command yet"
            if math.isinf(latency)
            else f"last speed command {age_text(latency)} ago"
        )
        state = "forwarding" if c.arbiter.tablet_speed is not None else "idle"
        self.watchdog_label.setText(
            f"{since}; ceiling {c.arbiter.watchdog.ceiling_s * 1000:.0f} ms; {state}; "
            f"discarded {c.arbiter.tablet_discarded}"
        )
