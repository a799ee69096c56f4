"""Timing diagnostics (thesis §6.4, Fig. 6.6 and Table 6.8): the normalised distribution of the
``clock()`` period (Fig. 6.6b) and of the period of received tablet speed commands (Fig. 6.6a,
Table 6.8), from `PeriodStats`, with mean, standard deviation and percentiles. Redrawn once a
second (every 40 frames of the controller's 25 ms timer).
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from base_station_app.station_controller import StationController
from interbot_core.watchdog import PeriodStats

REDRAW_EVERY_FRAMES = 40


def summary_text(stats: PeriodStats, threshold: float) -> str:
    s = stats.summary(threshold)
    if s.count == 0:
        return "no samples yet"
    return (
        f"n={s.count}  mean {s.mean * 1000:.1f} ms  std {s.std * 1000:.1f} ms  "
        f"p50 {s.p50 * 1000:.1f}  p99 {s.p99 * 1000:.1f}  max {s.maximum * 1000:.1f} ms  "
        f"> {threshold * 1000:.0f} ms: {s.above_threshold}"
    )


class QtDiagnosticsPanel(QWidget):
    """Two normalised histograms of periods [ms]."""

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        self._frames = 0
        layout = QVBoxLayout(self)
        self.plots: dict[str, tuple[pg.PlotWidget, pg.BarGraphItem, QLabel]] = {}
        for key, title in (
            ("clock", "clock() period (Fig. 6.6b)"),
            ("tablet", "received tablet speed command period (Fig. 6.6a)"),
        ):
            plot = pg.PlotWidget(background="w", title=title)
            plot.setLabel("bottom", "period [ms]")
            plot.setLabel("left", "share of periods [%]")
            plot.getAxis("left").enableAutoSIPrefix(False)
            bars = pg.BarGraphItem(x=[], height=[], width=1.0, brush=(30, 110, 220))
            plot.addItem(bars)
            label = QLabel()
            layout.addWidget(plot, 1)
            layout.addWidget(label)
            self.plots[key] = (plot, bars, label)
        controller.frame_ready.connect(self._on_frame)
        self.redraw()

    def _on_frame(self) -> None:
        self._frames += 1
        if self._frames % REDRAW_EVERY_FRAMES == 0:
            self.redraw()

    def redraw(self) -> None:
        c = self._controller
        for key, stats, threshold in (
            ("clock", c.clock_periods, c.clock_timer.interval() / 1000.0 * 1.5),
            ("tablet", c.arbiter.tablet_periods, c.config.latency_ceiling),
        ):
            _, bars, label = self.plots[key]
            values, edges = stats.histogram(bins=30)
            centres = (edges[:-1] + edges[1:]) / 2.0 * 1000.0
            width = float(np.diff(edges).mean() * 1000.0) if stats.count else 1.0
            if not math.isfinite(width) or width <= 0:
                width = 1.0
            bars.setOpts(x=centres, height=np.asarray(values) * 100.0, width=width * 0.9)
            label.setText(summary_text(stats, threshold))
